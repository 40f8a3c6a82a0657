"""Trajectories helpers (crowdmotion.trajectories)."""

import numpy as np

from crowdmotion.trajectories import held_absent


def test_rows_out_of_the_scene_are_held_where_the_agent_next_stands_or_last_stood():
    frames = np.arange(12, dtype=float).reshape(6, 2, 1) * np.ones((1, 1, 2))  # agent a: 0, 2, 4 ...; b: 1, 3, 5 ...
    present = np.array([[False, True], [False, True], [True, True], [True, False], [False, False], [True, True]])
    out = held_absent(frames.copy(), present)
    np.testing.assert_array_equal(out[:, 0, 0], [4, 4, 4, 6, 6, 10])  # before it came in: where it came in
    np.testing.assert_array_equal(out[:, 1, 0], [1, 3, 5, 5, 5, 11])  # after it left: where it last stood
    never = np.zeros((6, 2), dtype=bool)
    np.testing.assert_array_equal(held_absent(frames.copy(), never), frames)  # nobody in: as given
