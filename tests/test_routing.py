"""Routes round walls shared by the methods: descending the exact field, straight lines."""

import numpy as np

import crowdmotion as cm
from crowdmotion.groups import Rect
from crowdmotion.routing import distance_fields


def test_small_fields_by_scipy_equal_large_ones_by_the_mdp_fast_solver(monkeypatch):
    # fields up to SCIPY_MAX_CELLS are solved by scipy's Dijkstra (nothing to compile),
    # larger ones by the MDP bucket solver: the same distances either way
    from crowdmotion.mdp import solvers

    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([8, 2], [10, 10]), cm.Circle([15, 4], 1.5)])
    goals = [Rect([18, 8], [19.5, 9.5]), Rect([1, 1], [2, 2])]
    by_scipy = distance_fields(scene, goals, 0.3, 0.25)
    monkeypatch.setattr(solvers, "SCIPY_MAX_CELLS", 0)
    by_bucket = distance_fields(scene, goals, 0.3, 0.25)
    assert np.array_equal(np.isfinite(by_scipy.dist), np.isfinite(by_bucket.dist))
    finite = np.isfinite(by_scipy.dist)
    assert finite.sum() > 5000
    np.testing.assert_allclose(by_scipy.dist[finite], by_bucket.dist[finite], atol=1e-9)


def test_descending_the_field_gets_nearer_the_goal_by_the_cells_walked():
    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    f = distance_fields(scene, [Rect([18, 4], [19, 6])], 0.25, 0.5)
    start = np.array([[2.25, 5.25]])
    aim = f.descent_path(0, start, 6)[:, -1]
    assert f.at(0, aim)[0] == f.at(0, start)[0] - 6 * 0.5, "six straight cells down an open field"
    assert np.array_equal(f.descent_path(0, np.array([[-5.0, 5.0]]), 6)[:, -1], [[-5.0, 5.0]]), "off the grid: stays"


def test_the_descent_path_walks_one_cell_at_a_time_down_the_field_to_its_end():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8])])
    f = distance_fields(scene, [Rect([17, 1], [19, 3])], 0.25, 0.25)
    start = np.array([[8.0, 2.0], [-5.0, 5.0]])
    path = f.descent_path(0, start, 120)
    assert path.shape == (2, 121, 2)
    assert np.array_equal(path[:, 0], start) and np.array_equal(path[1], np.repeat(start[1:], 121, axis=0))
    steps = np.abs(np.diff(path[0, 1:], axis=0)) / 0.25
    assert np.all(np.isclose(steps, 0) | np.isclose(steps, 1)), "to one of the 8 cells around, or staying"
    value = f.at(0, path[0, 1:])
    assert np.all(np.diff(value) <= 0) and value[-1] == 0.0, "always down the field, to the goal"


def test_descending_goes_round_a_wall_not_through_it():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8])])
    f = distance_fields(scene, [Rect([17, 1], [19, 3])], 0.25, 0.25)
    aim = f.descent_path(0, np.array([[8.0, 2.0]]), 12)[0, -1]
    assert aim[1] > 2.0 + 2.0, "from beside the wall the way leads up round its end"


def test_line_of_sight_agrees_with_dense_sampling_of_the_clearance():
    # the exact segment test (crowdmotion._contact) against the scene's own distances sampled
    # every centimetre along each segment
    from crowdmotion._contact import line_of_sight
    from crowdmotion.obstacle_primitives import ObstacleSet

    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8]), cm.Circle([15, 7], 1.0),
                                                           cm.Polygon([[3, 6], [5, 6], [4, 8]])])
    rng = np.random.default_rng(3)
    a = rng.uniform([0.5, 0.5], [19.5, 9.5], (300, 2))
    b = rng.uniform([0.5, 0.5], [19.5, 9.5], (300, 2))
    prims = ObstacleSet(scene, "test", "test").at(0.0, 0.1)
    got = np.empty(300, dtype=bool)
    line_of_sight(a, b, np.full(300, 0.3), np.ones(300, bool), prims.circ_c, prims.circ_r, prims.seg_a,
                  prims.seg_b, got)
    t = np.linspace(0, 1, 2000)
    pts = a[:, None] + t[None, :, None] * (b - a)[:, None]
    sampled = (scene.static_obstacle_distance(pts.reshape(-1, 2)).reshape(300, -1) >= 0.3).all(axis=1)
    start_inside = scene.static_obstacle_distance(a) < 0  # a segment wholly inside one box never crosses an edge
    assert (got == sampled)[~start_inside].mean() > 0.99
