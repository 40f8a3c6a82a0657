"""Facing: the way a character looks, per frame, smooth and defined while it stands.

The heading of a velocity jitters (an MDP walker's moves alternate between grid
directions), flips when an agent is nudged backwards and is undefined when it stands.
A character rig needs none of that. :func:`facing_from_motion` gives every agent a yaw
(and, in 3D, a pitch) per frame:

1. the direction of travel over a centred window of ``window_s`` seconds (so stair-step
   grid paths face their mean direction);
2. it is updated only while the agent walks at more than ``standing_fraction`` of its
   own cruising speed (the 90th percentile of its speeds); standing, waiting at a goal
   or being pushed about at a crawl holds the last facing; before the first move the
   agent already faces the way it will go, and standing, it turns to the way it will
   walk over the half turn's time (pi / ``max_turn_rate``) before it sets off, so that it
   does not walk off backwards while it turns;
3. the turn from frame to frame is at most ``max_turn_rate`` radians per second.

:func:`turn_towards` is the same rule applied causally, one step at a time, for a
simulator stepped live (``rvo.Simulator.facing``): it cannot look ahead, so it turns
towards the velocity of the step just taken (not the centred window), walking means
faster than ``standing_fraction`` of the agent's preferred speed (its cruising speed
before the run has shown one), and an agent that has not moved yet faces its goal.

Methods that know better pass their own yaw to :class:`~crowdmotion.trajectories.Trajectories`
(a car's pair angle, a soldier facing his formation's heading); exporters write
whichever the Trajectories carries.
"""

from __future__ import annotations

import numpy as np

WINDOW_S = 0.5  # seconds of motion the direction of travel is taken over
STANDING_FRACTION = 0.25  # below this share of its cruising speed an agent holds its facing
MAX_TURN_RATE = 4.0  # rad/s: about a quarter turn in 0.4 s, a brisk turn on the spot


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles into [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def travel_velocity(positions: np.ndarray, dt: float, window_s: float = WINDOW_S) -> np.ndarray:
    """(T, N, D) velocity over a centred window of about ``window_s`` seconds (shorter at
    the ends of the run)."""
    t = positions.shape[0]
    if t < 2:
        return np.zeros_like(positions)
    k = max(1, int(round(window_s / (2 * dt))))
    idx = np.arange(t)
    lo, hi = np.maximum(idx - k, 0), np.minimum(idx + k, t - 1)
    return (positions[hi] - positions[lo]) / ((hi - lo) * dt)[:, None, None]


def hold_defined(values: np.ndarray, defined: np.ndarray, fallback: float = 0.0, lead: int = 0) -> np.ndarray:
    """(T, N): each value where ``defined``, else the last defined one before it, else the
    first defined one after it (an agent faces the way it will go before it moves), else
    ``fallback``. Within ``lead`` frames before the next defined one, that next one: an
    agent standing turns to the way it will walk before it sets off, not while."""
    t = values.shape[0]
    frames = np.arange(t)[:, None]
    frame = np.where(defined, frames, -1)
    last = np.maximum.accumulate(frame, axis=0)
    first = np.argmax(defined, axis=0)
    src = np.where(last >= 0, last, first[None, :])
    if lead > 0:
        nxt = np.minimum.accumulate(np.where(defined, frames, t)[::-1], axis=0)[::-1]
        src = np.where(~defined & (nxt < t) & (nxt - frames <= lead), nxt, src)
    out = np.take_along_axis(values, src, axis=0)
    return np.where(defined.any(axis=0)[None, :], out, fallback)


def limit_turn(target: np.ndarray, max_step: float) -> np.ndarray:
    """(T, N) angles that follow ``target`` turning at most ``max_step`` radians per frame
    the short way round; the first frame is the target's."""
    out = np.empty_like(target)
    out[0] = wrap(target[0])
    for t in range(1, target.shape[0]):
        out[t] = wrap(out[t - 1] + np.clip(wrap(target[t] - out[t - 1]), -max_step, max_step))
    return out


def facing_from_motion(positions: np.ndarray, dt: float, active: np.ndarray | None = None, *,
                       window_s: float = WINDOW_S, standing_fraction: float = STANDING_FRACTION,
                       max_turn_rate: float = MAX_TURN_RATE) -> tuple[np.ndarray, np.ndarray]:
    """(yaw, pitch), each (T, N) radians: yaw about the up axis from +x, pitch above the
    x-y plane (zeros in 2D). See the module docstring for the rules."""
    positions = np.asarray(positions, float)
    t, n, d = positions.shape
    v = travel_velocity(positions, dt, window_s)
    live = np.ones((t, n), bool) if active is None else np.asarray(active, bool)
    flat = np.linalg.norm(v[..., :2], axis=-1)
    full = np.linalg.norm(v, axis=-1)
    step = max_turn_rate * dt

    count = live.sum(axis=0)

    def walking(speed):
        ranked = np.sort(np.where(live, speed, np.inf), axis=0)  # inactive frames sort last
        at = np.clip(np.floor(0.9 * (count - 1)).astype(np.int64), 0, t - 1)
        cruise = np.where(count > 0, np.take_along_axis(ranked, at[None, :], axis=0)[0], 0.0)
        return live & (speed > np.maximum(standing_fraction * cruise, 1e-9))

    lead = int(np.ceil(np.pi / max_turn_rate / dt)) if max_turn_rate > 0 else 0  # a half turn's frames
    yaw = limit_turn(hold_defined(np.arctan2(v[..., 1], v[..., 0]), walking(flat), lead=lead), step)
    if d == 2:
        return yaw, np.zeros((t, n))
    # pitch: the climb angle while flying, level while hovering (a drone does not hold a tilt)
    pitch = np.where(walking(full), np.arctan2(v[..., 2], flat), 0.0)
    return yaw, limit_turn(pitch, step)


def turn_towards(yaw: np.ndarray, velocity: np.ndarray, min_speed: np.ndarray, max_step: float,
                 stepped: np.ndarray | None = None) -> np.ndarray:
    """(N,) yaw after one step of the causal facing: each agent ``stepped`` (default all)
    moving faster than its ``min_speed`` turns towards its ``velocity``'s heading, the
    short way round, by at most ``max_step`` radians; the others hold theirs. A NaN yaw
    (an agent with no facing yet) takes the heading at once. ``velocity``: (N, 2)."""
    yaw = np.asarray(yaw, float)
    v = np.asarray(velocity, float)
    vx, vy = v[:, 0], v[:, 1]
    moving = vx * vx + vy * vy > min_speed * min_speed
    if stepped is not None:
        moving &= stepped
    target = np.arctan2(vy, vx)
    turn = np.clip(wrap(target - yaw), -max_step, max_step)  # the short way round
    new = np.where(np.isnan(yaw), target, yaw + turn)
    return np.where(moving, wrap(new), yaw)


def turn_rate(yaw: np.ndarray, dt: float) -> np.ndarray:
    """(T-1, N) absolute turn between frames, radians per second."""
    return np.abs(wrap(np.diff(yaw, axis=0))) / dt
