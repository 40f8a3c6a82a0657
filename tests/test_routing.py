"""Routes round walls shared by the methods: descending the exact field, straight lines."""

import numpy as np
import pytest

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


def _door(width: float) -> cm.Scene:
    """A 16 x 8 m floor cut at x 10-12 by a wall with a door ``width`` wide round y 4."""
    return cm.Scene(bounds=([0, 0], [16, 8]), obstacles=[cm.Box([10, 0], [12, 4 - width / 2]),
                                                          cm.Box([10, 4 + width / 2], [12, 8])])


@pytest.mark.parametrize("width", [0.45, 0.5, 0.55])
def test_a_door_a_body_fits_through_is_open_though_no_cell_centre_in_it_is_clear(width):
    # a researcher's narrow-door study: radius 0.2 m bodies, 0.2 m cells; the centres in a
    # 0.5 m door lie 0.15 m from its jambs, and the goal beyond it was "unreachable"
    fields = distance_fields(_door(width), [cm.Rect([14.5, 0.5], [15.8, 7.5])], 0.2)
    assert np.isfinite(fields.nearby(0, np.array([[5.0, 4.0], [1.0, 1.0]]))).all()


def test_a_door_narrower_than_a_body_stays_shut_and_other_walls_keep_their_cells():
    goal = [cm.Rect([14.5, 0.5], [15.8, 7.5])]
    shut = distance_fields(_door(0.38), goal, 0.2)
    assert np.isinf(shut.nearby(0, np.array([[5.0, 4.0]]))).all()
    # the open door's own cells are the only ones opened: elsewhere the blocked cells are
    # those whose centre lies within a radius of a wall, as without a narrow door
    scene = _door(0.5)
    fields = distance_fields(scene, goal, 0.2)
    centres = scene.lower + (np.indices(fields.blocked.shape).reshape(2, -1).T + 0.5) * fields.cell
    near_wall = (scene.static_obstacle_distance(centres) < 0.2).reshape(fields.blocked.shape)
    opened = near_wall & ~fields.blocked
    x, y = np.nonzero(opened)
    assert len(x) and (centres.reshape(*fields.blocked.shape, 2)[x, y, 1] > 3.7).all() and \
        (centres.reshape(*fields.blocked.shape, 2)[x, y, 1] < 4.3).all()


def test_a_crowd_whose_only_way_out_is_a_door_just_wider_than_a_body_goes_through_it():
    from crowdmotion import metrics, rvo

    scene = _door(0.45)
    group = cm.Group("crowd", 10, spawn=cm.Rect([5, 2], [9, 6]), goal=cm.Rect([14.5, 0.5], [15.8, 7.5]), radius=0.2)
    traj = rvo.simulate(scene, [group], rvo.RVOParams(goal_assignment="nearest"), np.random.default_rng(0))
    assert (traj.positions[-1, :, 0] > 12).all(), "everyone through the door"
    audit = metrics.collision_audit(traj, scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0


def test_a_narrow_door_a_body_fits_through_is_open_though_a_longer_way_round_exists():
    # SteerSuite's doorway-one-way: a corridor in an open world, cut by a wall with a 1.2 m
    # door; bodies of radius 0.5 m on 0.5 m cells fit through it (centre within y 0.4-0.6)
    # but no cell centre in it is clear. The floor stays joined round the corridor's ends,
    # so the door is a shortcut, not the only way: it was left shut and the field sent
    # walkers 65 m round the outside instead of 25 m through it.
    scene = cm.Scene(bounds=([-100, -100], [100, 100]), obstacles=[
        cm.Box([-20, 3.1], [20, 5]), cm.Box([-20, -3], [20, -1]), cm.Box([-0.2, -3], [0, -0.1]),
        cm.Box([-0.2, 1.1], [0, 5])])
    from crowdmotion.groups import Points

    f = distance_fields(scene, [Points(np.array([[15.0, 1.0]]))], 0.5)
    assert f.at(0, np.array([[-10.0, 2.0]]))[0] < 27.0, "through the door, not 65 m round the corridor"
    # a door narrower than a body stays shut: the way round it is the way
    shut = cm.Scene(bounds=([-100, -100], [100, 100]), obstacles=[
        cm.Box([-20, 3.1], [20, 5]), cm.Box([-20, -3], [20, -1]), cm.Box([-0.2, -3], [0, 0.05]),
        cm.Box([-0.2, 0.95], [0, 5])])
    g = distance_fields(shut, [Points(np.array([[15.0, 1.0]]))], 0.5)
    assert g.at(0, np.array([[-10.0, 2.0]]))[0] > 60.0
