"""Scene runs of the MDP method with moving obstacles (crowdmotion.mdp.simulation)."""

import numpy as np
import pytest

from crowdmotion.mdp.simulation import ESCAPE_VALUE, escape_values
from crowdmotion.scenario import parse_scenario, run_scenario

FORKLIFT = """
name = "forklift"
method = "mdp"
seed = {seed}

[scene]
bounds = [[0.0, 0.0], [24.0, 14.0]]
obstacles = [
  {{ shape = "box", lower = [5.0, 3.0], upper = [19.0, 4.0] }},
  {{ shape = "box", lower = [5.0, 10.0], upper = [19.0, 11.0] }},
  {{ shape = "box", lower = [2.0, 6.0], upper = [4.0, 8.0], path = {{ times = [0.0, 10.0, 20.0], positions = [[3.0, 7.0], [21.0, 7.0], [3.0, 7.0]] }} }},
]

[[groups]]
name = "robots"
count = 16
radius = 0.35
max_speed = 1.2
pref_speed = 1.0
spawn = {{ shape = "rect", lower = [0.5, 0.5], upper = [4.5, 5.5] }}
goal = {{ shape = "rect", lower = [19.0, 11.5], upper = [23.5, 13.5] }}

[[groups]]
name = "pickers"
count = 10
radius = 0.25
spawn = {{ shape = "rect", lower = [19.5, 0.2], upper = [23.8, 2.9] }}
goal = {{ shape = "rect", lower = [0.5, 11.5], upper = [4.5, 13.5] }}

[mdp]
remove_on_arrival = true
"""


def test_a_cell_the_obstacle_covers_soon_is_walked_out_of_the_shortest_way_and_never_into():
    occupied = np.zeros((7, 3), dtype=np.uint8)
    occupied[1:6, :] = 1  # a band five cells across, the obstacle's look-ahead
    hard = np.zeros_like(occupied)
    hard[3, :] = 1  # where it stands until the next solve
    values = np.where(occupied == 1, -np.inf, -10.0)[None]
    out = escape_values(values, occupied, hard)[0]
    assert np.all(out[[0, 6]] == -10.0)  # free cells as solved
    np.testing.assert_array_equal(out[[1, 5]], ESCAPE_VALUE - 1)  # a step out
    np.testing.assert_array_equal(out[[2, 4]], ESCAPE_VALUE - 2)  # two steps: out away from the obstacle
    assert np.all(out[3] == -np.inf)  # where the obstacle is: nobody stands
    assert out[1].max() < -10.0  # below any free cell's value: nobody steps in


@pytest.mark.parametrize("seed", [0, 2, 4, 5])
def test_robots_crossing_a_forklift_s_lane_are_never_run_over(seed):
    # robots that stepped into the lane before the forklift came into the look-ahead stood
    # there, walled in by the look-ahead's blocked cells, and were run over (13 of seeds 0-25)
    r = run_scenario(parse_scenario(FORKLIFT.format(seed=seed)), progress=False)
    s = r.summary
    assert s["agent_obstacle_penetrations"] == 0 and s["agent_agent_overlaps"] == 0
    assert s["arrival_rate"] == 1.0
    assert s["duration_s"] < 80  # and the run stops once everyone has left (it ran on to max_steps, 467 s)


def test_a_point_in_the_strip_the_grid_s_whole_cells_leave_at_the_scene_s_edge_takes_the_last_cell():
    import crowdmotion as cm
    from crowdmotion import mdp
    from crowdmotion.mdp.grid import rasterise
    from crowdmotion.mdp.simulation import region_cells

    grid = rasterise(cm.Scene(bounds=([0, 0], [10, 10])), 0.849)  # 11 cells a side: 9.34 m of the 10
    assert grid.shape == (11, 11)
    cells = region_cells(grid, cm.Points([[9.7, 9.0], [9.0, 9.99]]), "goal")
    assert cells.tolist() == [[10, 10], [10, 10]]
    with pytest.raises(ValueError, match=r"goal: point \[10.5, 9.0\] lies outside the scene \(its grid of 0.849 m "
                                         r"cells spans \[0.0, 0.0\]-\[9.34, 9.34\]\)"):
        region_cells(grid, cm.Points([[10.5, 9.0]]), "goal")


def test_goal_points_one_per_agent_are_said_to_be_the_group_s_goal_cells_not_each_agent_s():
    # a robotics user gave 40 robots a goal point each; 39 ended at another's point, and
    # the run said 100 % arrived
    import crowdmotion as cm
    from crowdmotion import mdp

    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    group = cm.Group("robots", 3, spawn=cm.Rect([1, 1], [4, 9]), goal=cm.Points([[17, 2], [17, 5], [17, 8]]),
                     radius=0.3)
    with pytest.warns(UserWarning, match="not agent k to point k; for a goal per agent give each its own group"):
        mdp.simulate(scene, [group], mdp.MDPParams(max_steps=5), np.random.default_rng(0))


def test_a_robot_walled_off_from_its_goal_is_said_so_from_python():
    # mdp.simulate ran on with the robot standing, saying nothing (metadata only)
    import crowdmotion as cm
    from crowdmotion import mdp

    wall = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 4.5]), cm.Box([9, 5.5], [10, 10])])
    group = cm.Group("g", 1, spawn=(2, 5), goal=(18, 5), radius=0.8)
    with pytest.warns(UserWarning, match=r"1 agent\(s\) \(e.g. 0\) cannot reach their goal on the grid"):
        mdp.simulate(wall, [group], mdp.MDPParams(max_steps=5), np.random.default_rng(0))


def test_starts_and_goals_are_the_centres_of_their_cells_within_half_a_cell_diagonal_of_the_points_given():
    # a robotics user found starts and goals 0.2-0.9 m off the poses given, at large cells
    import crowdmotion as cm
    from crowdmotion import mdp

    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    start, goal = np.array([2.6, 5.1]), np.array([17.3, 3.9])
    robot = cm.Group("r", 1, spawn=cm.Points([start]), goal=cm.Points([goal]), radius=0.3)
    for cell in (None, 1.27):
        traj = mdp.simulate(scene, [robot], mdp.MDPParams(cell_size=cell), np.random.default_rng(0))
        size = traj.metadata["cell_size"]
        grid = mdp.rasterise(scene, size)
        np.testing.assert_allclose(traj.positions[0, 0], grid.centers(grid.cell_of(start)), atol=1e-9)
        np.testing.assert_allclose(traj.positions[-1, 0], grid.centers(grid.cell_of(goal)), atol=1e-9)
        for given, got in ((start, traj.positions[0, 0]), (goal, traj.positions[-1, 0])):
            assert np.linalg.norm(got - given) <= size * np.sqrt(2) / 2
    # a point given at a cell's centre is kept exactly (docs/mdp.md's way to exact poses)
    centre = grid.centers(grid.cell_of(start))
    exact = cm.Group("r", 1, spawn=cm.Points([centre]), goal=cm.Points([goal]), radius=0.3)
    traj = mdp.simulate(scene, [exact], mdp.MDPParams(cell_size=1.27), np.random.default_rng(0))
    np.testing.assert_allclose(traj.positions[0, 0], centre, atol=1e-9)


def test_two_robots_in_one_cell_are_refused_with_the_cell_size_and_the_finer_cells_that_part_them():
    # two one-robot groups 0.9 m apart were refused as "sharing a cell", nothing said of the cell size
    import crowdmotion as cm
    from crowdmotion import mdp

    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    a = cm.Group("r1", 1, spawn=cm.Points([[2.6, 5.1]]), goal=(18, 2), radius=0.3)
    b = cm.Group("r2", 1, spawn=cm.Points([[3.5, 5.2]]), goal=(18, 8), radius=0.3)
    with pytest.raises(ValueError, match=r"group 'r1' at \[2.6, 5.1\] and group 'r2' at \[3.5, 5.2\] fall in the "
                                         r"same grid cell of 1.27 m .*set a finer \[mdp\] cell_size, between "
                                         r"0.849 m .* and 0.9 m"):
        mdp.simulate(scene, [a, b], mdp.MDPParams(cell_size=1.27), np.random.default_rng(0))
    traj = mdp.simulate(scene, [a, b], mdp.MDPParams(cell_size=0.9, smoothing=None), np.random.default_rng(0))
    assert traj.positions.shape[1] == 2  # the finer cell suggested parts them
    close = cm.Group("r2", 1, spawn=cm.Points([[2.9, 5.3]]), goal=(18, 8), radius=0.3)
    with pytest.raises(ValueError, match=r"0.3 m apart along an axis, closer than the finest cell the bodies "
                                         r"allow, 0.849 m .*place them further apart"):
        mdp.simulate(scene, [a, close], mdp.MDPParams(), np.random.default_rng(0))


def _last_move_step(positions) -> int:
    moved = np.flatnonzero(np.abs(np.diff(positions, axis=0)).max(axis=(1, 2)) > 1e-9)
    return int(moved[-1]) + 1 if len(moved) else 0


def test_a_run_with_a_moving_obstacle_ends_once_every_agent_has_arrived_to_stay_not_at_max_steps():
    # mdp_moving_obstacle with arrivals staying ran on to max_steps: 560 steps (374 s of
    # frames) with the last move at step 83 (55 s)
    from crowdmotion.builtin import builtin_scenarios

    path = next(p for p in builtin_scenarios() if p.stem == "mdp_moving_obstacle")
    text = path.read_text().replace("max_steps = 150", "max_steps = 560")
    text = text.replace("remove_on_arrival = true", "remove_on_arrival = false\nsmoothing = \"none\"")
    stopped = run_scenario(parse_scenario(text, "staying"), progress=False)
    full = run_scenario(parse_scenario(text.replace("[mdp]", "[mdp]\nstop_when_done = false"), "staying"),
                        progress=False)
    assert full.summary["steps"] == 560 and stopped.summary["arrival_rate"] == 1.0
    last = _last_move_step(full.trajectories.positions)
    assert last < stopped.summary["steps"] <= last + 2  # within a replan (2 steps) of the last move: 84 of 560
    # the same steps up to there, and nobody moves in the steps it no longer runs
    np.testing.assert_array_equal(stopped.trajectories.positions, full.trajectories.positions[:stopped.summary["steps"] + 1])


def test_a_run_does_not_end_while_a_moving_obstacle_is_still_on_its_way_to_the_arrived_agents():
    # the robots are all in their goal area after 14 s; a cart sets off at 30 s and parks in
    # that area at 45 s: the robots in its way must still step aside
    text = """
name = "cart_parks_in_goal"
method = "mdp"
seed = 1
[scene]
bounds = [[0.0, 0.0], [20.0, 10.0]]
obstacles = [
  { shape = "box", lower = [1.0, 8.5], upper = [2.5, 9.5], path = { times = [0.0, 30.0, 45.0], positions = [[1.75, 9.0], [1.75, 9.0], [16.0, 5.0]] } },
]
[[groups]]
name = "robots"
count = 8
radius = 0.3
spawn = { shape = "rect", lower = [1.0, 1.0], upper = [5.0, 7.0] }
goal = { shape = "rect", lower = [14.0, 1.0], upper = [19.0, 9.0] }
[mdp]
max_steps = 400
smoothing = "none"
"""
    r = run_scenario(parse_scenario(text, "cart"), progress=False)
    full = run_scenario(parse_scenario(text + "stop_when_done = false\n", "cart"), progress=False)
    traj, s = r.trajectories, r.summary
    assert s["agent_obstacle_penetrations"] == 0 and s["agent_agent_overlaps"] == 0 and s["arrival_rate"] == 1.0
    dt = traj.dt
    moves = np.flatnonzero(np.abs(np.diff(full.trajectories.positions, axis=0)).max(axis=(1, 2)) > 1e-9) + 1
    assert moves[-2] * dt < 14 and moves[-1] * dt > 30  # all in by 14 s; one steps aside after the cart sets off
    assert 45 <= s["duration_s"] < 60  # it ran on until the cart stood for good, then ended (not at 320 s)
    np.testing.assert_array_equal(traj.positions, full.trajectories.positions[:s["steps"] + 1])
