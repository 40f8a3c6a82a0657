"""The add-on's planted feet (crowdmotion_blender/footlock.py, numpy alone, so checked
here without Blender): through every contact the crowdmotion channels give, the ankle that
the returned leg angles put in the world (forward kinematics, written out here from the
bone lengths) stays where it was put down, whichever way the body moves; a walker that
has stopped stands in its rest pose."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.blender import SOURCE
from crowdmotion.locomotion import RUN, WALK, locomotion

spec = importlib.util.spec_from_file_location("footlock", SOURCE / "footlock.py")
footlock = importlib.util.module_from_spec(spec)
spec.loader.exec_module(footlock)

FPS = 24.0
THIGH = SHIN = 0.43
HIP, HIP_WIDTH = 0.95, 0.1
# leg bones' rest frames as Blender gives them for bones pointing straight down (local Y
# along the bone); any other right-handed choice must give the same ankles
REST = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]).T


def rot(axis: int, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    m = np.zeros(angle.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m[..., axis, axis] = 1.0
    m[..., i, i], m[..., j, j], m[..., i, j], m[..., j, i] = c, c, -s, s
    return m


def euler_matrix(e: np.ndarray) -> np.ndarray:
    """Blender's XYZ Euler: X first, then Y, then Z."""
    return rot(2, e[..., 2]) @ rot(1, e[..., 1]) @ rot(0, e[..., 0])


def paths() -> tuple[Trajectories, np.ndarray]:
    """Five walkers 8 s long, and the way each faces: forward, sideways (facing 90° off
    its motion), backwards, round a 2 m circle speeding up, and one that slows to a stop and
    sets off again."""
    t = np.arange(int(8 * FPS) + 1) / FPS
    pos = np.zeros((len(t), 5, 2))
    pos[:, 0] = np.stack([1.3 * t, np.zeros_like(t)], 1)
    pos[:, 1] = np.stack([0.9 * t, np.full_like(t, 3.0)], 1)
    pos[:, 2] = np.stack([-1.0 * t, np.full_like(t, 6.0)], 1)
    arc = 0.3 * t + 0.06 * t ** 2  # 0.6 m/s to 1.56 m/s round a 2 m circle
    pos[:, 3] = np.stack([10 + 2 * np.cos(arc), 10 + 2 * np.sin(arc)], 1)
    # 1.2 m/s, slowing to a stand at 0.8 m/s² by 2.5 s, standing till 5 s, then setting off
    speed = np.clip(np.maximum((2.5 - t) * 0.8, (t - 5.0) * 0.8), 0.0, 1.2)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / FPS)])
    pos[:, 4] = np.stack([x, np.full_like(t, 15.0)], 1)
    facing = np.arctan2(np.gradient(pos[..., 1], axis=0), np.gradient(pos[..., 0], axis=0))
    facing[:, 1] += np.pi / 2  # faces north, walks east: its left side leads
    facing[:, 2] += np.pi  # faces east, walks west
    facing[:, 4] = 0.0
    return Trajectories(pos, 1 / FPS, radius=[0.25] * 5, facing=facing, metadata={"facing": "given"}), facing


def posed_ankles(tr: Trajectories, facing: np.ndarray):
    loco = locomotion(tr)
    t, n = facing.shape
    position = np.concatenate([tr.positions, np.zeros((t, n, 1))], axis=2)
    yaw = np.unwrap(facing + np.pi / 2, axis=0)  # the walker faces -Y at rest
    standing = (loco.gait_state != WALK) & (loco.gait_state != RUN)
    rest = {f"{b}.{s}": REST for b in ("thigh", "shin", "foot") for s in "LR"}
    pose = footlock.pose(position, yaw, loco.contact_left, loco.contact_right, standing, standing.astype(float), rest)
    ankles = np.empty((t, n, 2, 3))
    for k, (side, sign) in enumerate((("L", 1.0), ("R", -1.0))):
        c_thigh = REST @ euler_matrix(pose[f"thigh.{side}"]) @ REST.T
        c_shin = c_thigh @ REST @ euler_matrix(pose[f"shin.{side}"]) @ REST.T
        hip = np.zeros((t, n, 3))
        hip[..., 0], hip[..., 2] = sign * HIP_WIDTH, HIP + pose["hips"]
        local = hip + THIGH * (c_thigh @ [0.0, 0.0, -1.0]) + SHIN * (c_shin @ [0.0, 0.0, -1.0])
        c, s = np.cos(yaw), np.sin(yaw)
        ankles[:, :, k, 0] = position[..., 0] + c * local[..., 0] - s * local[..., 1]
        ankles[:, :, k, 1] = position[..., 1] + s * local[..., 0] + c * local[..., 1]
        ankles[:, :, k, 2] = local[..., 2]
    return loco, pose, ankles


def test_a_planted_foot_stays_put_whichever_way_the_body_moves():
    tr, facing = paths()
    loco, pose, ankles = posed_ankles(tr, facing)
    for k, contact in enumerate((loco.contact_left, loco.contact_right)):
        for i in range(tr.n_agents):
            edges = np.flatnonzero(np.diff(np.r_[0, contact[:, i].astype(np.int8), 0]))
            spells = list(zip(edges[::2], edges[1::2]))
            assert len(spells) >= 5, i  # it does step
            for a, b in spells:
                foot = ankles[a:b, i, k]
                assert np.linalg.norm(foot[:, :2] - foot[0, :2], axis=1).max() < 1e-6, (i, k, a)
                np.testing.assert_allclose(foot[:, 2], 0.09, atol=1e-6)  # flat on the ground
    swing = ~np.stack([loco.contact_left, loco.contact_right], axis=2)
    assert ankles[..., 2][swing].max() > 0.15  # lifted between contacts
    # the hips drop so the legs reach: 0.13 m in a stride at 1.3 m/s, 0.18 m at 1.56 m/s;
    # more in the first stride from a stand, which covers more ground
    walking = loco.gait_state == WALK
    assert -0.2 < pose["hips"][:, :4][walking[:, :4]].min() and pose["hips"].min() > -0.35


def test_a_walker_that_has_stopped_stands_in_its_rest_pose():
    tr, facing = paths()
    loco, pose, ankles = posed_ankles(tr, facing)
    stopped = slice(int(4 * FPS), int(4.5 * FPS))  # agent 4 stands from 2.5 s to 5 s
    assert (loco.gait_state[stopped, 4] != WALK).all()
    for bone in ("thigh.L", "shin.L", "foot.L", "thigh.R", "shin.R", "foot.R"):
        assert np.abs(pose[bone][stopped, 4]).max() < 1e-6, bone
    assert pose["hips"][stopped, 4] == pytest.approx(0.0, abs=1e-9)
    # feet under the hips, hip-width apart
    for k in range(2):
        np.testing.assert_allclose(ankles[stopped, 4, k, 0], tr.positions[stopped, 4, 0], atol=1e-9)
    np.testing.assert_allclose(ankles[stopped, 4, 0, 1] - ankles[stopped, 4, 1, 1], 2 * HIP_WIDTH, atol=1e-9)
