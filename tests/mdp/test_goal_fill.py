"""Goals that fill: agents walk into the free space of a goal area, and a point goal
shared by a crowd becomes slots round the point."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import mdp
from crowdmotion.mdp.adapter import goal_test
from crowdmotion.mdp.goal_fill import fill_depth, nearest_cells
from crowdmotion.mdp.simulation import run
from crowdmotion.metrics import collision_audit


def test_depth_in_an_open_square_is_the_straight_distance_to_its_edge():
    grid = np.zeros((20, 20), np.uint8)
    cells = np.argwhere(np.ones((8, 8), bool)) + 6  # the square 6..13
    depth = fill_depth(grid, cells, corner_cutting=False)
    i, j = cells.T - 6
    expected = np.minimum.reduce([i, j, 7 - i, 7 - j])  # independent: steps to the nearest rim cell
    assert np.array_equal(depth[tuple(cells.T)], expected)
    assert depth.sum() == expected.sum(), "no depth outside the goal"


def test_depth_toward_a_point_is_largest_at_the_point():
    grid = np.zeros((15, 15), np.uint8)
    slots = nearest_cells(grid, np.array([[7, 7]]), 9, corner_cutting=False)
    assert {tuple(c) for c in slots} == {(7 + a, 7 + b) for a in (-1, 0, 1) for b in (-1, 0, 1)}
    depth = fill_depth(grid, slots, False, toward=np.array([[7, 7]]))
    assert depth[7, 7] == depth.max() and depth[6, 7] < depth[7, 7] and depth[6, 6] < depth[6, 7]


def test_nearest_cells_refuses_more_agents_than_reachable_cells():
    grid = np.ones((5, 5), np.uint8)
    grid[1:3, 1:3] = 0
    with pytest.raises(ValueError, match="only 4 free cells"):
        nearest_cells(grid, np.array([[1, 1]]), 5, False)


def _crowd_to(goal, count=24, seed=3):
    scene = cm.Scene(bounds=([0, 0], [24, 12]), obstacles=[cm.Box([8, 0], [9, 4.5]), cm.Box([8, 7.5], [9, 12])])
    group = cm.Group("crowd", count, spawn=cm.Rect([0.5, 0.5], [6.5, 11.5]), goal=goal, radius=0.3)
    params = mdp.MDPParams(max_steps=400)
    result = run(scene, [group], params, np.random.default_rng(seed))
    return scene, result


def test_a_crowd_fills_a_goal_area_instead_of_stopping_on_its_rim():
    scene, result = _crowd_to(cm.Rect([16, 3], [20.5, 9]))
    reached = goal_test(result)(result.trajectories.positions[-1])
    assert reached.all(), f"{(~reached).sum()} agents never entered the goal area"
    audit = collision_audit(result.trajectories, scene)
    assert audit.clean, audit.events[:3]


def test_a_goal_area_too_small_for_a_crowd_that_stays_is_refused_before_the_run():
    # a disc of 1 m radius holds about 6 of the 0.6 m cells: 24 agents staying there could
    # never all arrive, and the run would idle to max_steps
    with pytest.raises(ValueError, match=r"group 'crowd' goal: disc .* holds \d+ free grid cells .* 24 agents "
                                         r"cannot all arrive.*remove_on_arrival"):
        _crowd_to(cm.Disc([18.0, 6.0], 1.0))
    scene = cm.Scene(bounds=([0, 0], [24, 12]))
    group = cm.Group("crowd", 24, spawn=cm.Rect([0.5, 0.5], [6.5, 11.5]), goal=cm.Disc([18.0, 6.0], 1.0), radius=0.3)
    result = run(scene, [group], mdp.MDPParams(max_steps=400, remove_on_arrival=True), np.random.default_rng(3))
    assert not result.trajectories.active_mask[-1].any(), "leaving on arrival, everyone gets there"


def test_a_point_goal_shared_by_a_crowd_becomes_slots_round_the_point():
    scene, result = _crowd_to(cm.Points([[18.0, 6.0]]), count=20)
    assert len(result.goal_cells[0]) == 20, "one slot per agent"
    final = result.trajectories.positions[-1]
    assert goal_test(result)(final).all(), "every agent ends in a slot"
    # the slots are the cells nearest the point: all within a small disc round it
    assert np.linalg.norm(final - [18.0, 6.0], axis=1).max() < 3 * result.grid.cell_size


def test_latecomers_go_round_to_the_free_side_of_a_full_goal_area():
    # a goal disc entered from the west fills its west half first; before the free-goal
    # values a latecomer random-walked round its rim (seed 1 of mdp_diversity: 130 steps)
    scene = cm.Scene(bounds=([0, 0], [30, 20]), obstacles=[cm.Box([11, 4], [13, 12])])
    starts = np.array([[1.5 + 1.2 * (i % 5), 6.0 + 1.2 * (i // 5)] for i in range(30)])
    group = cm.Group("robots", 30, spawn=cm.Points(starts), goal=cm.Disc([26.5, 10.0], 3.3), radius=0.3)
    for seed in range(6):
        result = run(scene, [group], mdp.MDPParams(max_steps=400), np.random.default_rng(seed))
        traj = result.trajectories
        assert goal_test(result)(traj.positions[-1]).all(), seed
        steps = traj.metadata["steps"]
        assert steps <= 90, f"seed {seed}: {steps} steps to settle"
        assert collision_audit(traj, scene).clean


def test_a_3d_goal_above_the_ceiling_is_said_to_lie_outside_the_scene():
    scene = cm.Scene(bounds=([0, 0, 0], [20, 20, 10]))
    group = cm.Group("drones", 4, spawn=cm.Rect([1, 1, 1], [5, 5, 3]), goal=cm.Rect([12, 12, 11], [16, 16, 12]),
                     radius=0.3)
    with pytest.raises(ValueError, match=r"group 'drones' goal: rect \[12, 12, 11\]-\[16, 16, 12\] lies outside "
                                         r"the scene: its grid of .* m cells spans"):
        run(scene, [group], mdp.MDPParams(max_steps=10), np.random.default_rng(0))
