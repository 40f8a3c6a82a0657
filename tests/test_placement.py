"""Placing bodies: goal points, and whole formations, moved to where they stand
(placement.standing_points, placement.standing_centre)."""

import numpy as np
import pytest

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


# a lattice spawn: a dense block start (placement.lattice_positions, groups.Lattice)

def test_lattice_sites_are_a_triangular_lattice_centred_in_the_rectangle():
    # 10 x 3 m at 1 m: rows 0.866 m apart (4 fit), 11 sites in the even rows, 10 in the shifted ones
    sites = cm.Lattice([0, 0], [10, 3]).sites(1.0)
    assert len(sites) == 11 + 10 + 11 + 10
    ys = np.unique(np.round(sites[:, 1], 9))
    np.testing.assert_allclose(np.diff(ys), np.sqrt(3) / 2)
    np.testing.assert_allclose(ys[0], 3 - ys[-1])  # as much room at the bottom as at the top
    from scipy.spatial import cKDTree
    d, _ = cKDTree(sites).query(sites, k=2)
    np.testing.assert_allclose(d[:, 1], 1.0)  # every site's nearest neighbour exactly a spacing off


def test_a_lattice_block_reaches_densities_random_draws_do_not():
    from crowdmotion.placement import spawn_positions
    from scipy.spatial.distance import pdist

    scene = cm.Scene(bounds=([0, 0], [30, 4]), obstacles=[cm.Box([0, 3], [30, 4])])
    block = cm.Group(name="block", count=108, spawn=cm.Lattice([1, 0], [11, 3]), goal=cm.Rect([28, 1], [29, 2]))
    pos = spawn_positions(scene, block, np.empty((0, 2)), np.empty(0), 0.05, np.random.default_rng(0))
    assert len(pos) == 108 and len(pos) / 30 == 3.6  # persons/m² over the rectangle
    assert pdist(pos).min() >= 0.5 + 0.05 - 1e-9  # bodies the gap apart
    assert scene.clearance(pos).min() >= 0.3 - 1e-9  # clear of the bounds and the wall box
    # a rect's random draws get nowhere near: the placement gives up
    with pytest.raises(ValueError, match="could not place 108 agents"):
        spawn_positions(scene, cm.Group(name="r", count=108, spawn=cm.Rect([1, 0.3], [11, 2.7]), goal=[28, 1.5]),
                        np.empty((0, 2)), np.empty(0), 0.05, np.random.default_rng(0))


def test_a_sparse_lattice_spreads_its_agents_evenly_over_the_rectangle():
    from crowdmotion.placement import spawn_positions
    from scipy.spatial import cKDTree

    scene = cm.Scene(bounds=([0, 0], [20, 20]))
    g = cm.Group(name="b", count=40, spawn=cm.Lattice([2, 2], [12, 12]), goal=[18, 18])
    pos = spawn_positions(scene, g, np.empty((0, 2)), np.empty(0), 0.05, np.random.default_rng(3))
    d, _ = cKDTree(pos).query(pos, k=2)
    # the widest spacing that holds 40 in 10 x 10 m, sites on the edges too: (10/s + 1)(10/(s·√3/2) + 1)
    # = 40 at s = 2.02 m; the rows and columns come in whole numbers: a little less
    assert 1.7 < np.median(d[:, 1]) < 2.02
    assert np.allclose(d[:, 1], np.median(d[:, 1]))  # all on one lattice
    assert np.ptp(pos[:, 0]) > 8 and np.ptp(pos[:, 1]) > 8


def test_a_lattice_keeps_clear_of_bodies_already_placed_and_says_how_many_fit():
    from crowdmotion.placement import spawn_positions

    scene = cm.Scene(bounds=([0, 0], [10, 10]))
    placed = np.array([[3.0, 3.0]])
    g = cm.Group(name="b", count=30, spawn=cm.Lattice([1, 1], [5, 5]), goal=[9, 9])
    pos = spawn_positions(scene, g, placed, np.array([0.25]), 0.05, np.random.default_rng(0))
    assert np.linalg.norm(pos - placed, axis=1).min() >= 0.55 - 1e-9
    with pytest.raises(ValueError, match=r"lattice \[1, 1\]-\[5, 5\] holds at most \d+ agents .* count = 500"):
        spawn_positions(scene, cm.Group(name="b", count=500, spawn=cm.Lattice([1, 1], [5, 5]), goal=[9, 9]),
                        np.empty((0, 2)), np.empty(0), 0.05, np.random.default_rng(0))


def test_lattice_positions_stay_inside_the_rectangle():
    from crowdmotion.placement import spawn_positions

    scene = cm.Scene(bounds=([0, 0], [30, 4]))
    for count in (10, 33, 60, 71):
        g = cm.Group(name="b", count=count, spawn=cm.Lattice([1, 0.5], [8, 3.5]), goal=[28, 2])
        pos = spawn_positions(scene, g, np.empty((0, 2)), np.empty(0), 0.05, np.random.default_rng(count))
        assert len(pos) == count
        assert np.all(pos >= [1, 0.5]) and np.all(pos <= [8, 3.5])


@pytest.mark.parametrize("seed", range(5))
def test_a_spawn_area_reaching_the_scene_edge_places_every_body_inside_the_bounds(seed):
    # a user's spawn [0, 0]-[3, 10] in a [0, 0]-[20, 10] scene: the run refused it, at
    # random, for an agent drawn within its radius of the edge
    from crowdmotion.placement import spawn_positions

    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    group = cm.Group("edge", 60, spawn=cm.Rect([0, 0], [3, 10]), goal=cm.Rect([18, 0], [20, 10]), radius=0.25)
    pos = spawn_positions(scene, group, np.zeros((0, 2)), np.zeros(0), 0.05, np.random.default_rng(seed))
    assert len(pos) == 60
    assert (pos >= 0.25).all() and (pos[:, 0] <= 19.75).all() and (pos[:, 1] <= 9.75).all()


def test_the_whole_run_takes_a_spawn_and_an_entrance_along_the_edge():
    from crowdmotion import rvo

    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    group = cm.Group("edge", 40, spawn=cm.Rect([0, 0], [3, 10]), goal=cm.Rect([18, 0], [20, 10]), radius=0.25,
                     attributes={"enter": {"rate": 20.0, "entrances": [cm.Rect([0, 9.6], [3, 10])]}})
    traj = rvo.simulate(scene, [group], rvo.RVOParams(max_steps=8), np.random.default_rng(3))
    assert traj.n_agents == 40


def test_a_spawn_inside_an_obstacle_is_named_as_such_from_python_too():
    from crowdmotion import rvo

    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([2, 2], [8, 8])])
    group = cm.Group("a", 5, spawn=cm.Rect([3, 3], [7, 7]), goal=cm.Rect([15, 1], [19, 9]))
    with pytest.raises(ValueError, match=r"rect \[3, 3\]-\[7, 7\] lies in obstacles"):
        rvo.simulate(scene, [group], rvo.RVOParams(max_steps=5), np.random.default_rng(0))
