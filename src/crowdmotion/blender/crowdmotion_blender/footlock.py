"""Planted feet for the built-in walker: where each ankle is on every frame, and the leg
pose that puts it there.

A foot that the run's contact channel says is down stays at one point of the ground for
the whole contact (its *plant*), whatever the body does meanwhile: walks on, steps
sideways or backwards, turns over it, speeds up or slows down. Between two contacts it
swings, lifted, from one plant to the next. The hips drop where a planted foot lies
farther from its hip than a straight leg reaches; a two-bone IK with the knee towards the
character's front gives thigh and shin, and the foot keeps the heading it was planted
with. Where a foot is put down:

- a contact while walking: under its hip on average over the contact's walking frames,
  so the leg sweeps evenly from front to back (and from side to side when walking
  sideways or backwards);
- one that starts standing and walks off: under its hip where it was put down;
- one while standing (idle, turning on the spot, inactive, or the closing steps after a
  stop): under its hip on average, so a stopped walker, once its closing steps are done,
  stands with its feet under it in its rest pose.

Runs inside Blender (numpy only, no bpy), on arrays (T frames, N agents); Blender's world
is Z up and the walker faces −Y with its left leg on +X.
"""

from __future__ import annotations

import numpy as np

ANKLE = 0.09  # m: ankle height over the ground with the foot flat
THIGH = SHIN = 0.43  # m
LEG = THIGH + SHIN
HIP = ANKLE + LEG  # m: hip height standing
HIP_WIDTH = 0.1  # m: each hip joint's distance from the middle
REACH = 0.985  # share of the leg's length a walking stance may use (knees never locked)
REST = np.array([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]]).T  # a leg bone's rest frame (columns: along, front, knee axis)


def rot_z(angle: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations about Z by ``angle``."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = c, -s, s, c
    out[..., 2, 2] = 1.0
    return out


def spells(contact: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contacts of a (T, N) bool array, agent by agent: (agent, first frame, end frame)."""
    t, n = contact.shape
    flat = np.zeros((n, t + 2), np.int8)
    flat[:, 1:-1] = contact.T
    edges = np.diff(flat, axis=1)
    agent_on, first = np.nonzero(edges == 1)
    agent_off, end = np.nonzero(edges == -1)
    return agent_on, first, end  # nonzero goes row by row: starts and ends pair up


def plants(hip: np.ndarray, yaw: np.ndarray, contact: np.ndarray, standing: np.ndarray):
    """Where and with which heading each contact of one foot is planted.

    Parameters
    ----------
    hip : (T, N, 3) that hip joint's ground point (world), per frame
    yaw : (T, N) the body's heading (unwrapped)
    contact : (T, N) bool, the foot is down
    standing : (T, N) bool, the agent stands (not walking or running)

    Returns
    -------
    (agent, first, end, point (S, 3), heading (S,)) per contact S.
    """
    agent, first, end = spells(contact)
    stepping = ~standing

    def span_mean(x, weight):
        """Per contact: the mean of ``x`` (T, N, ...) over its frames of ``weight``."""
        w = weight.reshape(weight.shape + (1,) * (x.ndim - 2)).astype(float)
        csum = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x * w, axis=0)])
        count = np.concatenate([np.zeros((1,) + x.shape[1:2]), np.cumsum(weight, axis=0)])
        k = count[end, agent] - count[first, agent]
        return (csum[end, agent] - csum[first, agent]) / np.maximum(k, 1).reshape(k.shape + (1,) * (x.ndim - 2)), k

    point, walking = span_mean(hip, stepping)
    heading, _ = span_mean(yaw, stepping)
    still_point, _ = span_mean(hip, np.ones_like(standing))
    still_heading, _ = span_mean(yaw, np.ones_like(standing))
    moves = walking > 0
    point = np.where(moves[:, None], point, still_point)
    heading = np.where(moves, heading, still_heading)
    # a contact from standing into walking: under the hip where it was put down (the
    # body may creep before its state says it walks)
    start = standing[first, agent] & moves
    point = np.where(start[:, None], hip[first, agent], point)
    heading = np.where(start, yaw[first, agent], heading)
    return agent, first, end, point, heading


def ankle_paths(hip: np.ndarray, yaw: np.ndarray, contact: np.ndarray, standing: np.ndarray):
    """(ankle (T, N, 3) world, foot heading (T, N)) of one foot on every frame: at its plant
    through each contact, on a lifted arc from plant to plant between them (from under its
    hip on the first frame before its first contact, to under its hip on the last after its
    last)."""
    t, n = contact.shape
    agent, first, end, point, heading = plants(hip, yaw, contact, standing)
    # each frame's contact before it (or at it) and after it, by index into the contacts
    idx = np.full((t, n), -1, np.int64)
    idx[first, agent] = np.arange(len(agent))
    prev = np.maximum.accumulate(idx, axis=0)  # the latest contact begun at or before this frame
    nxt = np.full((t + 1, n), len(agent), np.int64)
    nxt[first, agent] = np.arange(len(agent))
    nxt = np.minimum.accumulate(nxt[::-1], axis=0)[::-1][:t]  # the first contact begun at or after
    frame = np.arange(t)[:, None]
    # a virtual contact under the hip before the first frame and after the last
    pad_point = np.concatenate([point, np.zeros((1, 3))])
    pad_heading = np.concatenate([heading, [0.0]])
    has_prev, has_next = prev >= 0, nxt < len(agent)
    p0 = np.where(has_prev[..., None], pad_point[prev], hip[0][None])
    h0 = np.where(has_prev, pad_heading[prev], yaw[0][None])
    t0 = np.where(has_prev, np.r_[end - 1, 0][prev], -1)
    p1 = np.where(has_next[..., None], pad_point[np.minimum(nxt, len(agent))], hip[-1][None])
    h1 = np.where(has_next, pad_heading[np.minimum(nxt, len(agent))], yaw[-1][None])
    t1 = np.where(has_next, np.r_[first, 0][np.minimum(nxt, len(agent))], t)
    s = np.clip((frame - t0) / np.maximum(t1 - t0, 1), 0.0, 1.0)
    ease = 0.5 * (1 - np.cos(np.pi * s))
    ankle = p0 + (p1 - p0) * ease[..., None]
    foot_heading = h0 + (h1 - h0) * ease
    stride = np.linalg.norm((p1 - p0)[..., :2], axis=-1)
    ankle[..., 2] += ANKLE + (0.06 + 0.03 * stride) * np.sin(np.pi * s)
    down = np.asarray(contact, bool)
    ankle[down] = p0[down] + [0.0, 0.0, ANKLE]  # in a contact: its plant (the latest begun)
    foot_heading[down] = h0[down]
    return ankle, foot_heading


def _frame(along: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(..., 3, 3) a leg bone's frame, columns (along, front, knee axis), as REST's."""
    return np.stack([along, np.cross(axis, along), axis], axis=-1)


def euler_xyz(m: np.ndarray) -> np.ndarray:
    """(..., 3) Blender's XYZ Euler angles of rotation matrices (..., 3, 3) (R = Rz Ry Rx)."""
    x = np.arctan2(m[..., 2, 1], m[..., 2, 2])
    y = np.arctan2(-m[..., 2, 0], np.hypot(m[..., 0, 0], m[..., 1, 0]))
    z = np.arctan2(m[..., 1, 0], m[..., 0, 0])
    return np.stack([x, y, z], axis=-1)


def leg_pose(ankle_local: np.ndarray, hip_joint: np.ndarray, foot_turn: np.ndarray):
    """Armature-space rotations (from rest) of thigh, shin and foot, each (..., 3, 3), that
    put the ankle at ``ankle_local`` (armature space) from a hip joint at ``hip_joint``,
    the knee towards the front (−Y), the foot turned ``foot_turn`` about Z from the body's
    heading; and the ankle they reach (the target, where a leg reaches it)."""
    d = ankle_local - hip_joint
    dist = np.linalg.norm(d, axis=-1)
    r = np.minimum(dist, LEG)
    down = np.array([0.0, 0.0, -1.0])
    dhat = np.where(dist[..., None] > 1e-9, d / np.maximum(dist, 1e-12)[..., None], down)
    front = np.array([0.0, -1.0, 0.0])
    axis = np.cross(dhat, front)
    norm = np.linalg.norm(axis, axis=-1)
    axis = np.where(norm[..., None] > 1e-6, axis / np.maximum(norm, 1e-12)[..., None], [-1.0, 0.0, 0.0])
    bend = np.cross(axis, dhat)  # in the leg's plane, towards the front
    cos_a = np.clip((THIGH ** 2 + r ** 2 - SHIN ** 2) / (2 * THIGH * np.maximum(r, 1e-9)), -1.0, 1.0)
    alpha = np.arccos(cos_a)
    thigh = np.cos(alpha)[..., None] * dhat + np.sin(alpha)[..., None] * bend
    reached = hip_joint + r[..., None] * dhat
    knee = hip_joint + THIGH * thigh
    shin = (reached - knee) / SHIN
    c_thigh = _frame(thigh, axis) @ REST.T
    c_shin = _frame(shin, axis) @ REST.T
    c_foot = rot_z(foot_turn)
    return c_thigh, c_shin, c_foot, reached


def pose(position, yaw, contact_left, contact_right, standing, idle_weight, rest: dict):
    """The walker's per-frame pose with its feet planted.

    Parameters
    ----------
    position : (T, N, 3) root (world, Z up)
    yaw : (T, N) rotation about Z turning the walker (facing −Y) to its heading, unwrapped
    contact_left, contact_right : (T, N) bool, each foot down
    standing : (T, N) bool, the agent is not walking or running
    idle_weight : (T, N) in [0, 1], 1 while standing (fading over the blend): the knees
        straighten fully only there
    rest : bone name -> (3, 3) its rest orientation in armature space (``matrix_local``)

    Returns
    -------
    dict: ``hips`` (T, N) the hips' drop (m, ≤ 0); ``thigh.L``, ``shin.L``, ``foot.L``, ...
    (T, N, 3) each bone's XYZ Euler angles relative to its parent; ``swing.L``/``swing.R``
    (T, N) each thigh's forward swing (rad, for the arms); ``ankle`` (T, N, 2, 3) the
    ankles' world targets and ``reached`` (T, N, 2, 3) where the legs put them.
    """
    t, n = yaw.shape
    right_of = np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], axis=-1)  # the body's local +X in the world
    feet = {}
    for side, sign, contact in (("L", 1.0, contact_left), ("R", -1.0, contact_right)):
        hip = position + sign * HIP_WIDTH * right_of
        hip[..., 2] = position[..., 2]
        feet[side] = ankle_paths(hip, yaw, np.asarray(contact, bool), standing)
    to_local = rot_z(-yaw)  # world -> armature (about the root)

    def local(p):
        return np.einsum("tnij,tnj->tni", to_local, p - position)

    # the hips drop so that a planted foot is within reach
    reach = np.zeros((t, n))
    for side, sign, contact in (("L", 1.0, contact_left), ("R", -1.0, contact_right)):
        a = local(feet[side][0])
        horiz = np.hypot(a[..., 0] - sign * HIP_WIDTH, a[..., 1])
        reach = np.maximum(reach, np.where(contact, horiz, 0.0))
    leg = (REACH + (1 - REACH) * np.clip(idle_weight, 0, 1)) * LEG
    height = np.minimum(HIP, ANKLE + np.sqrt(np.maximum(leg ** 2 - reach ** 2, 0.25 * LEG ** 2)))
    height = _smooth_below(height, 3)
    out = {"hips": height - HIP, "ankle": np.empty((t, n, 2, 3)), "reached": np.empty((t, n, 2, 3))}
    for k, (side, sign) in enumerate((("L", 1.0), ("R", -1.0))):
        ankle, foot_heading = feet[side]
        joint = np.zeros((t, n, 3))
        joint[..., 0], joint[..., 2] = sign * HIP_WIDTH, height
        c_thigh, c_shin, c_foot, reached = leg_pose(local(ankle), joint, foot_heading - yaw)
        for bone, parent, mine in (("thigh", None, c_thigh), ("shin", c_thigh, c_shin), ("foot", c_shin, c_foot)):
            r = np.asarray(rest[f"{bone}.{side}"], float)
            change = mine if parent is None else np.swapaxes(parent, -1, -2) @ mine
            out[f"{bone}.{side}"] = euler_xyz(r.T @ change @ r)
        thigh_dir = -c_thigh[..., :, 2]  # where the thigh points: its rest direction (0, 0, -1) turned
        out[f"swing.{side}"] = np.arctan2(-thigh_dir[..., 1], -thigh_dir[..., 2])
        out["ankle"][:, :, k] = ankle
        out["reached"][:, :, k] = position + np.einsum("tnji,tnj->tni", to_local, reached)
    return out


def _smooth_below(x: np.ndarray, k: int) -> np.ndarray:
    """``x`` (T, N) smoothed over time without rising above it anywhere: the mean over
    ±k frames of its minimum over ±k frames."""
    t = x.shape[0]
    if t < 2 or k < 1:
        return x
    pad = np.concatenate([np.repeat(x[:1], k, 0), x, np.repeat(x[-1:], k, 0)])
    low = np.min(np.stack([pad[j:j + t] for j in range(2 * k + 1)]), axis=0)
    pad = np.concatenate([np.repeat(low[:1], k, 0), low, np.repeat(low[-1:], k, 0)])
    smooth = np.mean(np.stack([pad[j:j + t] for j in range(2 * k + 1)]), axis=0)
    return np.minimum(smooth, x)  # the mean of minima over windows that hold this frame is below it already
