"""benchmarks/room_exit_paths.py: the walking away from and sideways to a door, counted by hand."""

import runpy
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "room_exit_paths.py"


def test_steps_towards_away_and_across_the_line_to_the_door_are_split_by_hand():
    measures = runpy.run_path(str(SCRIPT), run_name="room_exit_paths")["measures"]
    # one walker on the door's line (y = 5): 2 m towards the door, 1 m back, then 1 m across
    # (0.5 m steps, 0.25 s apart), inside the room all along; the second has left after a step
    x = np.array([4.0, 4.5, 5.0, 5.5, 6.0, 5.5, 5.0, 5.0, 5.0])
    y = np.array([5.0] * 7 + [5.5, 6.0])
    first = np.stack([x, y], axis=1)
    second = np.array([[2.0, 5.0], [2.5, 5.0]] + [[2.5, 5.0]] * 7)
    positions = np.stack([first, second], axis=1)
    active = np.ones((9, 2), dtype=bool)
    active[2:, 1] = False
    m = measures(positions, active, 0.25)
    off = np.hypot(5.15, 0.5)  # the last step starts 0.5 m off the line: the door lies 5.15 m on, 0.5 m back
    # towards: 2 m, and the second walker's 0.5 m; away: 1 m, and the last step's share along the line
    assert np.isclose(m["away"], (1.0 + 0.5 * 0.5 / off) / 2.5)
    assert np.isclose(m["sideways"], (0.5 + 0.5 * 5.15 / off) / 2.5)
    assert np.isclose(m["path"], np.mean([4.0 / np.hypot(1.0, 1.0), 1.0]))  # 4 m walked for a diagonal 1 x 1 m
    assert m["out"] == 2.0
