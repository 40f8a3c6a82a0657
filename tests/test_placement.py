"""Placing bodies: goal points, and whole formations, moved to where they stand
(placement.standing_points, placement.standing_centre)."""

import numpy as np

import crowdmotion as cm
from crowdmotion.placement import GOAL_CLEARANCE_M, standing_centre, standing_points


def test_points_where_a_body_stands_are_kept_bit_for_bit():
    scene = cm.Scene(bounds=([0, 0], [20, 3]), obstacles=[cm.Box([8, 0], [9, 1])])
    pts = np.array([[5.0, 1.5], [10.0, 2.0], [19.5, 0.5]])
    out = standing_points(scene, pts, 0.25)
    assert np.array_equal(out, pts)


def test_a_point_at_the_scene_edge_moves_in_by_the_radius():
    scene = cm.Scene(bounds=([0, 0], [20, 3]))
    out = standing_points(scene, np.array([[19.98, 2.17], [3.0, 0.01]]), 0.25)
    need = 0.25 + GOAL_CLEARANCE_M
    np.testing.assert_allclose(out, [[20 - need, 2.17], [3.0, need]])


def test_a_point_beside_a_box_and_a_disc_moves_straight_out_of_their_reach():
    scene = cm.Scene(bounds=([0, 0], [20, 20]), obstacles=[cm.Box([8, 8], [10, 10]), cm.Circle([15, 5], 1.0)])
    need = 0.3 + GOAL_CLEARANCE_M
    out = standing_points(scene, np.array([[10.1, 9.0], [15.0, 6.1]]), 0.3)
    # the box's face x = 10: straight out along x; the disc: out along its radius
    np.testing.assert_allclose(out[0], [10 + need, 9.0], atol=1e-6)
    np.testing.assert_allclose(out[1], [15.0, 6.0 + need], atol=1e-6)
    assert np.all(scene.static_obstacle_distance(out) >= need - 1e-6)


def test_a_gap_narrower_than_the_body_gives_its_middle():
    scene = cm.Scene(bounds=([0, 0], [20, 0.4]))
    out = standing_points(scene, np.array([[5.0, 0.05]]), 0.25)
    np.testing.assert_allclose(out, [[5.0, 0.2]])


def _block(rows, cols, spacing=1.0):
    x, y = np.meshgrid(np.arange(cols) * spacing, np.arange(rows) * spacing)
    off = np.c_[x.ravel(), y.ravel()]
    return off - off.mean(axis=0)


def test_a_shape_that_fits_keeps_its_centre_bit_for_bit():
    scene = cm.Scene(bounds=([0, 0], [30, 10]), obstacles=[cm.Box([23, 2], [24, 8])])
    c = np.array([10.0, 5.0])
    assert np.array_equal(standing_centre(scene, c, _block(5, 5), 0.3), c)


def test_a_block_at_the_scene_edge_moves_in_until_its_outer_slots_keep_the_clearance():
    scene = cm.Scene(bounds=([0, 0], [30, 10]))
    # 3 rows x 4 columns 1 m apart: 1.5 m from its centre to its outer columns, 1 m to its rows
    out = standing_centre(scene, np.array([29.5, 9.8]), _block(3, 4), 0.3)
    np.testing.assert_allclose(out, [30 - 0.3 - 1.5, 10 - 0.3 - 1.0])


def test_a_shape_wider_than_the_scene_stands_in_its_middle_along_that_axis():
    scene = cm.Scene(bounds=([0, 0], [30, 3]))
    out = standing_centre(scene, np.array([12.0, 0.5]), _block(5, 2), 0.3)
    np.testing.assert_allclose(out, [12.0, 1.5])


def test_a_block_whose_front_column_stands_inside_a_box_backs_out_the_short_way():
    # the front column (x + 1) would stand in the middle of the box, where the signed
    # distance has no gradient: out west by 0.8 m, not east through the box by 2.8 m
    scene = cm.Scene(bounds=([0, 0], [30, 10]), obstacles=[cm.Box([23, 2], [24, 8])])
    out = standing_centre(scene, np.array([22.5, 5.0]), _block(3, 3), 0.3)
    np.testing.assert_allclose(out, [23 - 0.3 - 1.0, 5.0], atol=0.002)
    assert np.all(scene.static_obstacle_distance(out + _block(3, 3)) >= 0.3 - 1e-9)
