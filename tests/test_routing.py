"""Routes round walls shared by the methods: descending the exact field, straight lines."""

import numpy as np

import crowdmotion as cm
from crowdmotion.groups import Rect
from crowdmotion.routing import clear_lines, distance_fields


def test_descending_the_field_gets_nearer_the_goal_by_the_cells_walked():
    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    f = distance_fields(scene, [Rect([18, 4], [19, 6])], 0.25, 0.5)
    start = np.array([[2.25, 5.25]])
    aim = f.descend(0, start, 6)
    assert f.at(0, aim)[0] == f.at(0, start)[0] - 6 * 0.5, "six straight cells down an open field"
    assert np.array_equal(f.descend(0, np.array([[-5.0, 5.0]]), 6), [[-5.0, 5.0]]), "off the grid: stays"


def test_descending_goes_round_a_wall_not_through_it():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8])])
    f = distance_fields(scene, [Rect([17, 1], [19, 3])], 0.25, 0.25)
    aim = f.descend(0, np.array([[8.0, 2.0]]), 12)[0]
    assert aim[1] > 2.0 + 2.0, "from beside the wall the way leads up round its end"


def test_clear_lines_see_past_a_wall_only_where_there_is_no_wall():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8])])
    seen = clear_lines(scene, np.array([[2.0, 2.0], [2.0, 9.0]]), np.array([18.0, 9.0]), 0.3)
    assert seen.tolist() == [False, True]
