"""Trajectories helpers (crowdmotion.trajectories)."""

import numpy as np
import pytest

from crowdmotion.trajectories import Trajectories, held_absent, resample


def test_rows_out_of_the_scene_are_held_where_the_agent_next_stands_or_last_stood():
    frames = np.arange(12, dtype=float).reshape(6, 2, 1) * np.ones((1, 1, 2))  # agent a: 0, 2, 4 ...; b: 1, 3, 5 ...
    present = np.array([[False, True], [False, True], [True, True], [True, False], [False, False], [True, True]])
    out = held_absent(frames.copy(), present)
    np.testing.assert_array_equal(out[:, 0, 0], [4, 4, 4, 6, 6, 10])  # before it came in: where it came in
    np.testing.assert_array_equal(out[:, 1, 0], [1, 3, 5, 5, 5, 11])  # after it left: where it last stood
    never = np.zeros((6, 2), dtype=bool)
    np.testing.assert_array_equal(held_absent(frames.copy(), never), frames)  # nobody in: as given


def test_a_resampled_agent_stands_still_where_it_left_and_where_it_entered():
    # an exported plaza's leavers moved on for a few frames after leaving (0.4 m/s at 24 fps)
    t = np.arange(20) * 0.25
    x = np.where(t < 3.0, 1.3 * t, 1.3 * 3.0)  # walks, leaves at 3 s (held there)
    pos = np.stack([np.c_[x, np.zeros(20)], np.c_[x[::-1], np.ones(20)]], axis=1)
    active = np.stack([t < 3.0, t >= 2.0], axis=1)  # the second enters at 2 s
    out = resample(Trajectories(pos, 0.25, active=active), 24.0, "b-spline")
    for i in range(2):
        gone = ~out.active_mask[:, i]
        rows = out.positions[gone, i]
        assert len(rows) and np.ptp(rows, axis=0).max() < 1e-12, "still while out of the scene"


def test_a_resampled_walker_leaves_and_enters_at_its_pace():
    # held where it left, the B-spline slowed a leaver from 1.2 to 0.7 m/s over its last
    # frames (a Houdini TD's courtyard at 24 fps)
    t = np.arange(24) * 0.25
    x = np.where(t < 4.0, 1.2 * t, 1.2 * 3.75)
    pos = np.c_[x, np.zeros(24)][:, None, :]
    active = (t < 4.0)[:, None]
    out = resample(Trajectories(pos, 0.25, active=active), 24.0, "b-spline")
    p, a = out.positions[:, 0, 0], out.active_mask[:, 0]
    last = np.flatnonzero(a)[-1]
    speed = (p[last] - p[last - 1]) * 24
    assert speed == pytest.approx(1.2, rel=0.02)
