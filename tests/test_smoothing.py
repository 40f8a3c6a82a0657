"""crowdmotion.smoothing: splines re-checked in continuous time, falling back per step."""

import warnings

import numpy as np

from crowdmotion.metrics import collision_audit
from crowdmotion.smoothing import resample_checked
from crowdmotion.trajectories import Trajectories, resample

DT = 0.25
RADIUS_M = 0.66  # A circles B this far from its centre: the chords keep 0.61 m, two radii 0.6


def _circling() -> Trajectories:
    """Walker A comes in at 3 m/s, circles a standing B 45° a step (2 m/s: the chords stay
    clear of B, the B-spline, which cuts each frame's corner, does not) and walks off."""
    ang = np.deg2rad(np.arange(-90, 181, 45.0))
    ring = RADIUS_M * np.c_[np.cos(ang), np.sin(ang)]
    come = ring[0] + np.array([-0.75, 0.0]) * np.arange(4, 0, -1)[:, None]
    go = ring[-1] + np.array([0.0, -0.5]) * np.arange(1, 4)[:, None]
    a = np.vstack([come, ring, go])
    return Trajectories(np.stack([a, np.zeros_like(a)], axis=1), DT, radius=np.array([0.3, 0.3]))


def test_a_step_the_b_spline_cannot_keep_follows_a_spline_through_the_frames_not_a_corner():
    tr = _circling()
    assert collision_audit(resample(tr, 60, "linear"), None).agent_agent == 0
    assert collision_audit(resample(tr, 60, "b-spline"), None).agent_agent > 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = resample_checked(tr, 60, "b-spline", None, max_speed=np.zeros(2))
    assert collision_audit(out, None).agent_agent == 0
    done = out.metadata["resampled"]
    assert done["through_segments"] >= 4 and done["straight_segments"] <= 1
    # round B, straight moves would turn 45° within one 60 fps frame at every step
    # (93 m/s²); the spline through the frames turns over the steps, near the circle's own
    # centripetal acceleration
    p = out.positions[:, 0]
    acc = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=-1) / out.dt ** 2
    t = (np.arange(len(acc)) + 1) * out.dt
    centripetal = (np.linalg.norm(tr.positions[6, 0] - tr.positions[5, 0]) / DT) ** 2 / RADIUS_M
    assert acc[(t > 5 * DT) & (t < 9 * DT)].max() < 2 * centripetal
