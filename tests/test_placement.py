"""Placing bodies: goal points moved to where a body stands (placement.standing_points)."""

import numpy as np

import crowdmotion as cm
from crowdmotion.placement import GOAL_CLEARANCE_M, standing_points


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
