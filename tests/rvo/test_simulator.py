"""The interactive RVO simulator as a user drives it: bad state set by hand is refused."""

import re
import warnings

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.metrics import collision_audit


def _sim():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20])), time_step=0.25, rng=np.random.default_rng(0))
    sim.add_agents([[2, 2], [2, 6], [2, 10]], [[18, 2], [18, 6], [18, 10]])
    return sim


@pytest.mark.parametrize("array,agent,value", [("positions", 0, np.nan), ("velocities", 1, np.inf),
                                               ("goals", 2, -np.inf)])
def test_a_nan_position_raises_value_error_on_step_naming_the_agent(array, agent, value):
    sim = _sim()
    getattr(sim, array)[agent] = value  # in this process: a numba kernel given it would crash Python
    before = sim.positions.copy()
    with pytest.raises(ValueError, match=rf"^{array} of agent {agent} is not finite: {value}$"):
        sim.step()
    assert sim.steps == 0 and np.array_equal(sim.positions, before, equal_nan=True), "nothing moved"


def test_an_agent_that_has_arrived_may_hold_nan_and_the_others_walk_on():
    sim = _sim()
    sim.active[0] = False
    sim.positions[0] = np.nan
    sim.step()
    assert sim.steps == 1 and np.isfinite(sim.positions[1:]).all()


def test_a_walker_from_rest_reaches_its_speed_at_the_comfortable_acceleration():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 10])), comfort_accel=0.8)
    sim.add_agents([[1, 5]], [[39, 5]], pref_speed=1.2)
    speeds = []
    for _ in range(8):
        sim.step()
        speeds.append(float(np.linalg.norm(sim.velocities[0])))
    assert np.allclose(speeds[:5], 0.8 * 0.25 * np.arange(1, 6))  # 0.2 m/s more each 0.25 s step
    assert speeds[-1] == pytest.approx(1.2)


def test_a_walker_passing_its_goal_at_speed_turns_in_instead_of_circling_it():
    # at 1.3 m/s, 1 m to the side of its goal: a 0.8 m/s² turn has a radius of 2.1 m, so
    # without slowing it would circle the goal for good
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20])), comfort_accel=0.8)
    sim.add_agents([[10, 9]], [[10, 10]], pref_speed=1.3)
    sim.velocities[0] = [1.3, 0.0]
    while sim.time < 20 and sim.active.any():
        sim.step()
    assert sim.arrived.all() and sim.arrival_time[0] < 6.0, sim.arrival_time


# ---- the live API: new goals and removals between steps ---------------------------------------
def _walled():
    """A 20 × 10 m room split by a wall at x 9-11 with a door at y 4-6."""
    return cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [11, 4]), cm.Box([9, 6], [11, 10])])


def _record(sim, frames, present):
    frames.append(sim.positions.copy())
    present.append(sim.present.copy())


def test_a_crowd_rerouted_and_thinned_mid_run_reaches_its_new_goals_without_a_collision():
    rng = np.random.default_rng(3)
    scene = _walled()
    sim = rvo.Simulator(scene, rng=rng)
    starts = np.array([[1.0 + 1.2 * (k % 6), 1.0 + 1.4 * (k // 6)] for k in range(36)])
    ids = sim.add_agents(starts, [18, 5])
    frames, present = [], []
    _record(sim, frames, present)
    for _ in range(12):
        sim.step()
        _record(sim, frames, present)
    back = ids[::2]  # half of them change their minds: back to the west wall
    sim.set_goals(back, [1.0, 9.0])
    sim.remove_agents(ids[1:20:2])  # and ten others leave the scene
    for _ in range(400):
        if not (sim.active & ~sim.arrived).any():
            break
        sim.step()
        _record(sim, frames, present)
    assert sim.arrived[back].all(), "every rerouted agent reached its new goal"
    assert np.allclose(sim.goals[back], [1.0, 9.0])
    kept = np.setdiff1d(ids[1::2], ids[1:20:2])
    assert sim.arrived[kept].all() and not sim.arrived[ids[1:20:2]].any()
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    report = collision_audit(traj, scene)
    assert report.agent_agent == 0 and report.agent_obstacle == 0, report.events[:3]


def test_a_goal_inside_a_wall_is_refused_and_every_agent_keeps_its_goal():
    sim = rvo.Simulator(_walled())
    sim.add_agents([[2, 5], [3, 5]], [18, 5])
    sim.step()  # the guidance fields exist from here on
    with pytest.raises(ValueError, match=r"goals: \[10.0, 2.0\] \(the 1st of 1\) lies inside an obstacle"):
        sim.set_goals([0], [10, 2])
    assert np.allclose(sim.goals, [18, 5])
    sim.step()


def test_goals_no_body_can_reach_are_refused_when_added_and_the_simulation_goes_on():
    # a goal inside a wall, added mid-run, used to be accepted and then refuse every later
    # step (its guidance field unsolvable); one outside the bounds was walked at forever
    sim = rvo.Simulator(_walled())
    sim.add_agents([[2, 5], [3, 5]], [18, 5])
    sim.step()
    with pytest.raises(ValueError, match="lies inside an obstacle"):
        sim.add_agents([[2, 8]], [10, 2])
    with pytest.raises(ValueError, match=r"\[50.0, 5.0\] \(the 2nd of 2\) lies outside the scene bounds"):
        sim.add_agents([[2, 8], [2, 2]], [[18, 8], [50, 5]])
    with pytest.raises(ValueError, match="outside the scene bounds"):
        sim.set_goals([1], [18, -3])
    assert sim.n_agents == 2 and np.allclose(sim.goals, [18, 5])
    sim.step()


@pytest.mark.parametrize("region", [cm.Rect([40, 40], [50, 50]), cm.Disc([50, 50], 2.0),
                                    cm.Points([[25, 25], [-3, 4]])])
def test_a_goal_region_wholly_outside_the_scene_is_refused_before_the_first_step_and_after(region):
    # taken in before the first step, it made that step and every later one fail, even
    # once the agent sent there had gone
    for stepped in (False, True):
        sim = _sim()
        if stepped:
            sim.step()
        with pytest.raises(ValueError, match=r"goal_region: .* lies outside the scene bounds \[0.0, 0.0\]-\[20.0, 20.0\]"):
            sim.add_agents([[5, 15]], [[19, 19]], goal_region=region)
        with pytest.raises(ValueError, match="goal_region: .* lies outside the scene bounds"):
            sim.set_goals([0], [19, 19], goal_region=region)
        assert sim.n_agents == 3
        sim.step()
    sim.add_agents([[5, 15]], [[19, 19]], goal_region=cm.Rect([18, 18], [25, 25]))  # partly inside: its part serves
    sim.step()


def test_agents_added_together_with_their_own_goals_each_follow_their_own_field():
    # one call, two goal points on either side of a wall: each agent is guided to its own
    # goal, not to the nearer of the two (as agents added in two calls are)
    scene = cm.Scene(bounds=([0, 0], [30, 20]), obstacles=[cm.Box([10, 2], [12, 12])])
    together = rvo.Simulator(scene)
    together.add_agents([[5, 7], [2, 2]], [[20, 7], [5, 18]])
    apart = rvo.Simulator(scene)
    apart.add_agents([[5, 7]], [20, 7])
    apart.add_agents([[2, 2]], [5, 18])
    for sim in (together, apart):
        while not sim.arrived[0] and sim.steps < 400:
            sim.step()
    assert together.arrived[0] and together.time == apart.time
    assert together.field_of[0] != together.field_of[1]


def test_the_same_goal_given_again_reuses_its_guidance_field():
    sim = rvo.Simulator(_walled())
    sim.add_agents([[2, 5], [3, 7], [2, 2]], [18, 5])
    sim.step()
    for k in range(3):
        sim.set_goals([k], [18, 9])
        sim.step()
    assert sim._fields.dist.shape[0] == 2


def test_a_new_goals_field_is_solved_on_the_blocked_cells_found_before_and_is_the_same(monkeypatch):
    from crowdmotion import routing

    sim = rvo.Simulator(_walled())
    sim.add_agents([[2, 5], [3, 7]], [18, 5])
    sim.step()
    found = []
    real = routing.blocked_cells
    monkeypatch.setattr(routing, "blocked_cells", lambda *a, **kw: found.append(1) or real(*a, **kw))
    sim.set_goals([1], [18, 9])  # a new goal: its field solved now
    assert found == [], "the obstacles did not change: the blocked cells are those of the fields before"
    fresh = routing.distance_fields(sim._now, [sim._goal_regions[-1]], 0.25, sim._fields.cell)
    np.testing.assert_array_equal(sim._exact[-1], fresh.dist[0])
    graphs = []
    real_graph = routing.move_graph
    monkeypatch.setattr(routing, "move_graph", lambda *a, **kw: graphs.append(1) or real_graph(*a, **kw))
    for k, goal in enumerate(([18, 2], [15, 8], [12, 9])):  # a goal a frame, as a chase gives them
        sim.set_goals([0], goal)
        sim.step()
    assert len(graphs) <= 1, "the grid's moves are built once for the new goals' fields"
    fresh = routing.distance_fields(sim._now, [sim._goal_regions[-1]], 0.25, sim._fields.cell)
    np.testing.assert_array_equal(sim._exact[-1], fresh.dist[0])


def test_fields_added_one_at_a_time_fill_the_room_kept_for_them_instead_of_copying_all_held():
    from crowdmotion.rvo.simulator import _stacked

    held = np.arange(2 * 3 * 4, dtype=float).reshape(2, 3, 4)
    rows = _stacked(held, np.full((1, 3, 4), -1.0))
    buffer = rows.base
    assert len(buffer) > 3, "room kept for more"
    more = _stacked(rows, np.full((1, 3, 4), -2.0))
    assert more.base is buffer, "the next field went into that room"
    np.testing.assert_array_equal(more[:2], held)
    assert (more[2] == -1).all() and (more[3] == -2).all() and more.shape == (4, 3, 4)


def test_a_crowd_sent_to_ever_new_goals_keeps_fields_only_for_goals_in_use_and_a_few_more(monkeypatch):
    from crowdmotion.rvo import simulator as S
    monkeypatch.setattr(S, "UNUSED_FIELDS_MB", 0.0)  # keep the fewest unused fields: UNUSED_FIELDS_MIN
    sim = rvo.Simulator(_walled(), remove_on_arrival=False, rng=np.random.default_rng(0))
    ids = sim.add_agents([[2, 2], [2, 8], [18, 2]], [[18, 8]] * 3)
    exit_area = cm.Rect([17, 1], [19, 3])
    sim.add_goal_regions([exit_area])  # pinned: kept however long unused
    sim.step()
    rng = np.random.default_rng(1)
    for _ in range(40):  # each time a new goal point for one walker: a new field
        x = rng.choice([rng.uniform(1, 8), rng.uniform(12, 19)])
        sim.set_goals([int(rng.integers(3))], [x, rng.uniform(1, 9)])
        sim.step()
    assert len(sim._exact) <= len(ids) + 1 + S.UNUSED_FIELDS_MIN + 1
    # the fields in reused places are those of their new goals: the same distances as a fresh simulator's
    fresh = rvo.Simulator(_walled())
    fresh.add_agents([[2, 2]], [[18, 8]])
    fresh.step()
    for k in ids:
        region = sim._goal_regions[sim.field_of[k]]
        pts = np.array([[2.0, 5.0], [5.0, 9.0], [15.0, 1.5]])
        np.testing.assert_array_equal(sim.walking_distance(pts, region), fresh.walking_distance(pts, region))
    # and the pinned region's field is still there, solved once
    assert sim._goal_regions.index(exit_area) in sim._pinned
    # sent to the pinned region and back to a goal whose place went to another: everyone arrives
    sim.set_goals([ids[0]], exit_area.center, goal_region=exit_area)
    sim.set_goals([ids[1]], [18, 8])
    sim.set_goals([ids[2]], [2, 2])
    while sim.time < 60 and not (sim.arrived[ids].all()):
        sim.step()
    assert sim.arrived[ids].all()


def test_a_goal_region_object_given_again_after_its_field_went_to_another_gets_its_own_field_again(monkeypatch):
    from crowdmotion.rvo import simulator as S
    monkeypatch.setattr(S, "UNUSED_FIELDS_MB", 0.0)
    sim = rvo.Simulator(_walled(), remove_on_arrival=False, rng=np.random.default_rng(0))
    east = cm.Rect([16, 6], [19, 9])
    sim.add_agents([[2, 2]], east.center, goal_region=east)
    sim.step()
    for k in range(S.UNUSED_FIELDS_MIN + 3):  # east unused, then the longest unused: its place is reused
        sim.set_goals([0], [2.0 + 0.5 * k, 8.0])
        sim.step()
    assert all(r is not east for r in sim._goal_regions)
    sim.set_goals([0], east.center, goal_region=east)  # the same object: found by value, not by a stale id
    assert sim._goal_regions[sim.field_of[0]] is east
    while sim.time < 40 and not sim.arrived[0]:
        sim.step()
    assert sim.arrived[0]


def test_a_walker_added_far_from_the_others_on_their_congestion_field_finds_it_solved_where_it_stands():
    sim = rvo.Simulator(_walled(), remove_on_arrival=False, rng=np.random.default_rng(0))
    exit_area = cm.Rect([17, 1], [19, 9])
    near = np.stack(np.meshgrid([14.0, 15.0], [3.0, 5.0, 7.0]), -1).reshape(-1, 2)
    sim.add_agents(near, exit_area.center, goal_region=exit_area)
    sim.step()  # the congestion-aware field, solved as far as these walkers go before the next re-solve
    k = int(sim.field_of[0])
    west = tuple(np.floor((np.array([2.0, 5.0]) - sim._fields.origin) / sim._fields.cell).astype(int))
    assert k in sim._partial and np.isinf(sim._fields.dist[k][west])  # nothing solved west of the wall
    late = sim.add_agents([[2.0, 5.0]], exit_area.center, goal_region=exit_area)
    sim.step()
    assert np.isfinite(sim._fields.dist[k][west]) and k not in sim._partial
    while sim.time < 40 and not sim.arrived[late].all():
        sim.step()
    assert sim.arrived[late].all()


def test_a_congestion_field_nobody_walks_any_more_goes_back_to_the_exact_distances_at_the_next_re_solve():
    sim = rvo.Simulator(_walled(), rng=np.random.default_rng(0))
    north, south = cm.Rect([17, 7], [19, 9]), cm.Rect([17, 1], [19, 3])
    crowd = np.stack(np.meshgrid([2.0, 3.0, 4.0], [2.0, 4.0, 6.0, 8.0]), -1).reshape(-1, 2)
    a = sim.add_agents(crowd[:6], north.center, goal_region=north)
    sim.add_agents(crowd[6:], south.center, goal_region=south)
    sim.step()
    k = int(sim.field_of[a[0]])
    weighted = sim._fields.dist[k].copy()
    assert not np.array_equal(weighted, sim._exact[k])  # the crowd made it dearer somewhere
    sim.remove_agents(a)
    for _ in range(sim.replan_steps):
        sim.step()
    np.testing.assert_array_equal(sim._fields.dist[k], sim._exact[k])
    assert not np.array_equal(sim._fields.dist[1 - k], sim._exact[1 - k])


def test_an_agent_that_arrived_and_stayed_walks_again_when_given_a_new_goal():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])), remove_on_arrival=False)
    sim.add_agents([[5, 4.9]], [5, 5])
    sim.step()
    assert sim.arrived[0]
    sim.set_goals([0], [5, 9])
    assert not sim.arrived[0]
    while sim.time < 20 and not sim.arrived[0]:
        sim.step()
    assert sim.arrived[0] and np.linalg.norm(sim.positions[0] - [5, 9]) <= sim.arrival_radius


def test_a_removed_agent_no_longer_blocks_the_way():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 4])), remove_on_arrival=False)
    sim.add_agents([[2, 2], [10, 2]], [[18, 2], [10, 2]], radius=0.3)  # agent 1 stands on its goal, in the way
    sim.step()
    sim.remove_agents([1])
    ys = []
    while sim.time < 20 and not sim.arrived[0]:
        sim.step()
        ys.append(sim.positions[0, 1])
    assert sim.arrived[0] and np.max(np.abs(np.array(ys) - 2.0)) < 0.1, "walked on through where it stood (0.46 m round it if it stays)"


@pytest.mark.parametrize("call,args,message", [
    ("set_goals", ([5], [1, 1]), r"set_goals: no agent 5 \(ids run from 0 to 2\)"),
    ("set_goals", ([0], [np.nan, 1]), "goals"),
    ("set_goals", ([0, 1], [[1, 1], [2, 2], [3, 3]]), r"goals must be \(2,\) or \(2, 2\), got shape \(3, 2\)"),
    ("set_goals", ([0.5], [1, 1]), "agents must be a list of agent ids"),
    ("remove_agents", ([-1],), "remove_agents: no agent -1"),
])
def test_the_live_api_refuses_bad_calls_naming_the_agent_and_changes_nothing(call, args, message):
    sim = _sim()
    goals = sim.goals.copy()
    with pytest.raises(ValueError, match=message):
        getattr(sim, call)(*args)
    assert np.array_equal(sim.goals, goals) and sim.active.all()


def test_a_simulator_without_agents_says_so_when_one_is_named():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])))
    with pytest.raises(ValueError, match=r"drive: no agent 0 \(it has no agents yet\)"):
        sim.drive([0], [1.0, 0.0])


def test_an_agent_that_left_cannot_be_given_a_goal():
    sim = _sim()
    sim.remove_agents([1])
    with pytest.raises(ValueError, match="set_goals: agent 1 has left the simulation"):
        sim.set_goals([1], [5, 5])


# ---- the live API: obstacles that come and go --------------------------------------------------
def _room_with_door():
    """A 20 × 10 m room; a wall at x 9-11 with a 2 m doorway at y 4-6."""
    return cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [11, 4]), cm.Box([9, 6], [11, 10])])


def _crowd_behind_the_doorway(scene):
    """A simulator with 36 walkers west of the doorway bound east of it, the doorway
    blocked by a box; returns it, the box's index and the recorded frames so far."""
    sim = rvo.Simulator(scene, rng=np.random.default_rng(1))
    box = sim.add_obstacle(cm.Box([9.5, 4], [10.5, 6]))
    starts = np.array([[1.0 + 1.0 * (k % 6), 1.0 + 1.3 * (k // 6)] for k in range(36)])
    sim.add_agents(starts, [18, 5], radius=0.25)
    return sim, box, ([sim.positions.copy()], [sim.present.copy()])


def _step_recording(sim, record, until: float | None = None) -> None:
    """Step until ``until`` seconds, or (None) until everyone has arrived or 120 s,
    appending each frame's positions and who is drawn to ``record``."""
    frames, present = record
    while (sim.time < until - 1e-9) if until is not None else ((sim.active & ~sim.arrived).any() and sim.time < 120):
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())


def test_a_door_opened_at_20_s_lets_the_crowd_through_and_the_audit_knows_it_stood_before():
    scene = _room_with_door()
    sim, door, record = _crowd_behind_the_doorway(scene)  # the doorway is shut
    _step_recording(sim, record, until=20.0)
    assert (sim.positions[:, 0] < 9.5).all() and not sim.arrived.any(), "nobody got through the shut door"
    sim.remove_obstacle(door)
    _step_recording(sim, record)
    assert sim.arrived.all(), "the whole crowd went through once the door was open"
    assert len(scene.obstacles) == 2 and len(sim.scene.obstacles) == 3, "the user's scene is untouched"
    assert sim.scene.obstacles[door].present == (0.0, 20.0)
    frames, present = record
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    report = collision_audit(traj, sim.scene)
    assert report.agent_agent == 0 and report.agent_obstacle == 0, report.events[:3]
    # the same paths against a door that never opened cross it: the audit does look
    shut = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[*scene.obstacles, cm.Box([9.5, 4], [10.5, 6])])
    assert collision_audit(traj, shut).agent_obstacle > 0


def test_an_obstacle_dropped_on_an_agent_is_refused_and_nothing_changes():
    sim = rvo.Simulator(_room_with_door())
    sim.add_agents([[5, 5]], [18, 5])
    with pytest.raises(ValueError, match=r"add_obstacle: agent 0 at \[5.0, 5.0\] would stand inside"):
        sim.add_obstacle(cm.Circle([5.3, 5], 0.5))
    assert len(sim.scene.obstacles) == 2
    with pytest.raises(ValueError, match="remove_obstacle: no obstacle 7"):
        sim.remove_obstacle(7)
    with pytest.raises(ValueError, match="add_obstacle: a Circle, Box or Polygon is needed"):
        sim.add_obstacle("wall")


def test_an_obstacle_put_or_moved_wholly_outside_the_bounds_is_refused():
    sim = rvo.Simulator(_room_with_door())
    sim.add_agents([[5, 5]], [18, 5])
    with pytest.raises(ValueError, match=r"add_obstacle: Circle\(center=\[30.0, 5.0\].*wholly outside the scene"):
        sim.add_obstacle(cm.Circle([30, 5], 0.5))
    post = sim.add_obstacle(cm.Circle([3, 2], 0.5))
    with pytest.raises(ValueError, match=f"move_obstacle: obstacle {post} moved, .*wholly outside"):
        sim.move_obstacle(post, (0, -10))
    assert sim.scene_now.obstacles[-1].bounds()[0].tolist() == [2.5, 1.5]  # still where it stood
    half_out = sim.move_obstacle(post, (0, -2.2))  # partly outside the bounds: a wall may run past them
    assert np.allclose(sim.scene_now.obstacles[-1].bounds()[0], [2.5, -0.7])
    assert half_out == len(sim.scene.obstacles) - 1


def test_a_move_refused_for_an_agent_in_the_way_leaves_the_run_as_it_would_have_been():
    # the refusal used to take the obstacle out and put it back, rebuilding the fields:
    # the run went on differently (up to metres apart later)
    def crowd():
        scene = cm.Scene(bounds=([0, 0], [30, 30]), obstacles=[cm.Box([8, 8], [12, 12]), cm.Box([18, 20], [22, 24])])
        sim = rvo.Simulator(scene, time_step=1 / 30, rng=np.random.default_rng(2))
        starts = np.array([[x, y] for x in (2.0, 4.0) for y in np.arange(2.0, 28.0, 2.5)])
        sim.add_agents(starts, np.c_[np.full(len(starts), 27.0), starts[::-1, 1]])
        return sim

    tried, untouched = crowd(), crowd()
    for step in range(120):
        if step == 30:
            with pytest.raises(ValueError, match="move_obstacle: obstacle 1 moved, agent .* would stand inside"):
                tried.move_obstacle(1, cm.Box(tried.positions[0] - 1, tried.positions[0] + 1))
        tried.step()
        untouched.step()
    assert np.array_equal(tried.positions, untouched.positions, equal_nan=True)


def test_a_wall_put_across_the_way_sends_the_agents_round_it():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    sim.add_agents([[2, 5]], [18, 5])
    for _ in range(8):
        sim.step()
    wall = sim.add_obstacle(cm.Box([9, 2], [10, 8]))
    frames = [sim.positions.copy()]
    while sim.active.any() and sim.time < 60:
        sim.step()
        frames.append(sim.positions.copy())
    assert sim.arrived[0]
    assert sim.scene.obstacles[wall].present == (2.0, np.inf)
    path = np.array(frames)[:, 0]
    assert np.abs(path[:, 1] - 5).max() > 3.0, "it walked round the wall's end"
    sim.remove_obstacle(wall)
    with pytest.raises(ValueError, match="is not in the scene now"):
        sim.remove_obstacle(wall)


def test_a_scene_with_an_obstacle_that_came_and_went_round_trips_through_its_dict():
    scene = cm.Scene(bounds=([0, 0], [10, 10]), obstacles=[cm.Box([1, 1], [2, 2]).during(3.0, 7.5),
                                                             cm.Circle([5, 5], 1).during(2.0)])
    again = cm.Scene.from_dict(scene.to_dict())
    assert [o.present for o in again.obstacles] == [(3.0, 7.5), (2.0, np.inf)]
    assert again.obstacle_distance([[1.5, 1.5]], 5.0)[0] < 0 and again.obstacle_distance([[1.5, 1.5]], 8.0)[0] > 0
    assert scene.static_obstacles == [] and len(scene.at_time(5.0).static_obstacles) == 2


def test_an_obstacle_over_an_agents_goal_is_refused_and_the_agents_walk_on():
    sim = rvo.Simulator(_room_with_door())
    sim.add_agents([[2, 5]], [[18, 5]])
    sim.step()
    with pytest.raises(ValueError, match="add_obstacle: .* cannot go in: goal region 0: .*no cell free of obstacles"):
        sim.add_obstacle(cm.Box([17, 4], [19, 6]))
    assert len(sim.scene.obstacles) == 2
    while sim.active.any() and sim.time < 60:
        sim.step()
    assert sim.arrived[0]


def test_an_obstacle_taken_out_in_the_step_it_was_put_in_never_stood():
    sim = rvo.Simulator(_room_with_door())
    sim.add_agents([[2, 5]], [18, 5])
    sim.step()
    door = sim.add_obstacle(cm.Box([9.5, 4], [10.5, 6]))
    sim.remove_obstacle(door)
    assert sim.scene.obstacles[door].present == (0.25, 0.25)
    assert not sim.scene.obstacles[door].present_at(0.25)
    while sim.active.any() and sim.time < 60:
        sim.step()
    assert sim.arrived[0]


def test_set_goals_keeps_each_goal_with_its_agent_whatever_the_order_of_ids():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[2, 2], [2, 5], [2, 8]], [18, 5])
    sim.set_goals([ids[2], ids[0]], [[18, 9], [18, 1]])
    assert sim.goals[ids].tolist() == [[18, 1], [18, 5], [18, 9]]


@pytest.mark.parametrize("goals", [[10, 10], np.zeros((0, 2))])
def test_set_goals_with_no_agents_named_changes_nothing_as_drive_and_place_do(goals):
    # a game sends "everyone within range" on: np.flatnonzero(mask) may match no one
    sim = _sim()
    before = sim.goals.copy()
    none = np.flatnonzero(np.zeros(sim.n_agents, dtype=bool))
    sim.set_goals(none, goals)
    sim.drive(none, [1.0, 0.0])
    sim.place(none, [5.0, 5.0])
    assert np.array_equal(sim.goals, before)
    sim.step()
    with pytest.raises(ValueError, match="goals must be finite"):
        sim.set_goals(none, [np.nan, 1.0])  # the goal is still checked


def test_set_goals_names_an_id_given_twice_with_a_goal_each():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[2, 2], [2, 5]], [18, 5])
    with pytest.raises(ValueError, match=r"set_goals: agent 1 is given twice"):
        sim.set_goals([1, 1], [[15, 5], [16, 6]])
    sim.set_goals([ids[0], ids[0]], [15, 5])  # one goal for all: a repeat does no harm
    assert sim.goals[ids[0]].tolist() == [15, 5]


def test_set_goals_can_make_an_agent_stay_at_or_leave_by_its_goal():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    stays, goes = sim.add_agents([[2, 3], [2, 7]], [4, 5])
    sim.set_goals([stays], [4, 3], leave=False)
    sim.set_goals([goes], [4, 7], leave=True)
    for _ in range(20):
        sim.step()
    assert sim.arrived[[stays, goes]].all() and sim.active[stays] and not sim.active[goes]


# ---- the live API: routes set while running ----------------------------------------------------
def test_a_crowd_rerouted_mid_run_thinned_and_let_through_a_door_that_opens_follows_its_routes_cleanly():
    from crowdmotion.stages import GoTo, Leave, Queue, Wait

    scene = cm.Scene(bounds=([0, 0], [40, 14]), obstacles=[cm.Box([19, 0], [21, 6]), cm.Box([19, 8], [21, 14])])
    sim = rvo.Simulator(scene, rng=np.random.default_rng(2), remove_on_arrival=False)
    door = sim.add_obstacle(cm.Box([19.5, 6], [20.5, 8]))  # shut
    starts = np.array([[2.0 + 1.2 * (k % 9), 9.0 + 1.1 * (k // 9)] for k in range(40)])
    ids = sim.add_agents(starts, [6, 3])  # as docs/journeys.md writes it: the route decides
    west = Leave(cm.groups.Rect([0, 1], [0.5, 5]), name="west")
    sim.set_route(ids, [GoTo(cm.groups.Disc([6, 3], 2.5), arrive="free_point"), Wait({"uniform": [20.0, 30.0]}), west])
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.time < 8.0 - 1e-9:
        sim.step()
        _record(sim, frames, present)
    rerouted, removed = ids[::2], ids[1:20:2]
    sim.set_route(rerouted, [Queue([18.2, 7], rate=0.5, direction=[-1, 0], name="door"),
                             Leave(cm.groups.Rect([38, 5], [40, 9]), name="east")])
    sim.remove_agents(removed)
    for _ in range(8):
        sim.step()
        _record(sim, frames, present)
    sim.remove_obstacle(door)  # the door opens at 10 s
    while (sim.active | sim.waiting).any() and sim.time < 200:
        sim.step()
        _record(sim, frames, present)
    j = sim.journeys
    report = j.report(["all"])
    assert report["exits"]["east"]["left"] == 20 and report["exits"]["west"]["left"] == 10, report["exits"]
    assert report["removed"] == 10 and report["finished"] == 30
    served = j.queues[0].served  # first come (to the end of the line), first served
    assert len(served) == 20 and all(a[1] <= b[1] for a, b in zip(served, served[1:]))
    assert served[0][2] > 10.0, "nobody served before the door opened"
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    audit = collision_audit(traj, sim.scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0, audit.events[:3]


def test_a_route_that_does_not_fit_the_scene_is_refused_naming_the_stage_and_nothing_changes():
    from crowdmotion.stages import Leave, Queue

    sim = rvo.Simulator(_room_with_door())
    ids = sim.add_agents([[2, 5], [3, 2]], [5, 5])
    bad = [Queue([8.5, 2], rate=1.0, direction=[1, 0], name="gate"), Leave(cm.groups.Rect([19, 4], [20, 6]))]
    with pytest.raises(ValueError, match=r"set_route: route.0 \(queue 'gate'\): place 1 in line at \[9.15, 2\]"):
        sim.set_route(ids, bad)
    assert sim.journeys is None or not sim.journeys.on_route.any()
    with pytest.raises(ValueError, match=r"route.0 \(leave\).*must be the last stage"):
        sim.set_route(ids, [Leave(cm.groups.Rect([19, 4], [20, 6])), Queue([5, 5], rate=1.0, direction=[-1, 0])])


def test_a_barrier_moved_aside_at_10_s_lets_the_crowd_through_and_the_audit_is_clean():
    scene = _room_with_door()
    sim, barrier, record = _crowd_behind_the_doorway(scene)  # a barrier across the doorway
    _step_recording(sim, record, until=10.0)
    assert (sim.positions[:, 0] < 9.5).all(), "nobody got past the barrier"
    moved = sim.move_obstacle(barrier, (0.0, 2.0))  # pushed aside, into the wall's end
    _step_recording(sim, record)
    assert sim.arrived.all(), "the whole crowd went through once the barrier was aside"
    frames, present = record
    obs = sim.scene.obstacles
    assert obs[barrier].present == (0.0, 10.0) and obs[moved].present == (10.0, np.inf)
    assert np.allclose(obs[moved].lower, [9.5, 6]) and len(scene.obstacles) == 2, "the user's scene is untouched"
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    report = collision_audit(traj, sim.scene)
    assert report.agent_agent == 0 and report.agent_obstacle == 0, report.events[:3]
    # the same paths against a barrier that never moved cross it: the audit does look
    stayed = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[*scene.obstacles, cm.Box([9.5, 4], [10.5, 6])])
    assert collision_audit(traj, stayed).agent_obstacle > 0


@pytest.mark.parametrize("to,message", [
    ((-4.7, 1.0), r"move_obstacle: obstacle 2 moved, agent 0 at \[5.0, 5.0\] would stand inside"),
    (cm.Circle([18, 5], 0.5), r"move_obstacle: obstacle 2 moved, .* cannot go in"),
    ((0.0, 0.0, 1.0), r"move_obstacle: an obstacle or an offset \(dx, dy\) is needed"),
])
def test_a_move_onto_an_agent_or_its_goal_is_refused_and_nothing_changes(to, message):
    sim = rvo.Simulator(_room_with_door())
    barrier = sim.add_obstacle(cm.Box([9.5, 4], [10.5, 6]))
    sim.add_agents([[5, 5]], [[18, 5]])
    sim.step()
    before = list(sim.scene.obstacles)
    with pytest.raises(ValueError, match=message):
        sim.move_obstacle(barrier, to)
    assert sim.scene.obstacles == before and sim.scene.obstacles[barrier].present == (0.0, np.inf)
    with pytest.raises(ValueError, match="move_obstacle: no obstacle 9"):
        sim.move_obstacle(9, (1, 0))
    sim.step()
    assert sim.active.all()


# ---- the live API: agents the caller moves itself (a game's player, a robot) -------------------
def _street_with_player():
    """40 walkers heading west along a 30 × 10 m street; a player (radius 0.3) at its
    west end, driven east at 1.5 m/s straight through them."""
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [30, 10])), time_step=0.25)
    starts = np.array([[x, y] for x in (20, 22, 24, 26, 28) for y in np.linspace(1, 9, 8)])
    sim.add_agents(starts, np.c_[np.full(len(starts), 1.0), starts[:, 1]], radius=0.25)
    player = sim.add_agents([[2, 5]], [[2, 5]], radius=0.3, max_speed=3.0, pref_speed=1.5)
    sim.drive(player, [1.5, 0.0])
    return sim, int(player[0])


def _stepped(sim, steps):
    """``steps`` steps of ``sim`` from now, recorded as Trajectories (with the start)."""
    frames, present = [], []
    _record(sim, frames, present)
    for _ in range(steps):
        sim.step()
        _record(sim, frames, present)
    return cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))


def test_a_driven_player_walks_exactly_as_driven_and_the_crowd_steps_out_of_its_way():
    sim, player = _street_with_player()
    traj = _stepped(sim, 72)
    path = traj.positions[:, player]
    assert np.allclose(path[:, 0], 2.0 + 1.5 * sim.dt * np.arange(73)) and np.allclose(path[:, 1], 5.0)
    report = collision_audit(traj, sim.scene)
    assert report.agent_agent == 0 and report.agent_obstacle == 0, report  # nobody it met was hit
    assert not sim.arrived[player], "a driven agent does not arrive (its goal is behind it)"


def test_a_driven_agent_handed_back_walks_to_its_goal_again():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[2, 5]], [[18, 5]], radius=0.3)
    sim.drive(ids, [0.0, 1.0])  # north, away from the goal in the east
    for _ in range(8):
        sim.step()
    assert np.allclose(sim.positions[0], [2.0, 7.0])
    sim.drive(ids, None)
    while sim.time < 30 and not sim.arrived[0]:
        sim.step()
    assert sim.arrived[0]


def test_a_player_pushing_through_a_dense_standing_crowd_never_pushes_two_others_together():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [30, 10])), remove_on_arrival=False)
    spots = np.array([[x, y] for x in np.arange(10, 20, 0.8) for y in np.arange(1, 9.01, 0.8)])
    sim.add_agents(spots, spots, radius=0.25)  # 1.6 /m², standing on their spots
    player = int(sim.add_agents([[2, 5.1]], [[2, 5.1]], radius=0.3)[0])
    sim.drive([player], [1.2, 0.0])
    report = collision_audit(_stepped(sim, 80), sim.scene)
    assert all(player in (e.a, e.b) for e in report.events), "the crowd keeps clear of itself"


def test_place_teleports_an_agent_and_refuses_a_place_no_body_fits():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [11, 4])]))
    ids = sim.add_agents([[2, 5], [4, 5]], [[18, 5], [18, 5]], radius=0.3)
    sim.place(ids[:1], [15, 8])
    assert np.allclose(sim.positions[0], [15, 8])
    before = sim.positions.copy()
    for where, message in (([10, 2], "agent 1 at .* would be inside an obstacle"),
                           ([19.9, 5], "agent 1 at .* does not fit inside the scene bounds"),
                           ([15.3, 8], "agents 0 and 1 would be overlapped")):
        with pytest.raises(ValueError, match=message):
            sim.place([1], where)
        assert np.array_equal(sim.positions, before)
    sim.place([0], [15.2, 8])  # a small move of its own body is no overlap with itself


@pytest.mark.parametrize("call,args,message", [
    ("drive", ([0], [np.nan, 0]), "velocities"),
    ("drive", ([0, 1], [[1, 0]]), r"velocities must be \(2,\) or \(2, 2\)"),
    ("drive", ([7], [1, 0]), r"drive: no agent 7"),
    ("place", ([0], [np.inf, 1]), "positions"),
    ("place", ([0, 1], [[1, 1], [2, 2], [3, 3]]), r"positions must be \(2,\) or \(2, 2\)"),
])
def test_drive_and_place_refuse_bad_calls_and_change_nothing(call, args, message):
    sim = _sim()
    before = sim.positions.copy()
    with pytest.raises(ValueError, match=message):
        getattr(sim, call)(*args)
    assert np.array_equal(sim.positions, before) and not sim.driven.any()


def test_an_agent_still_waiting_to_enter_cannot_be_driven():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[2, 5]], [[18, 5]], enter_at=5.0)
    with pytest.raises(ValueError, match="drive: agent 0 has not entered yet"):
        sim.drive(ids, [1, 0])


def test_a_driven_agent_stops_at_the_edge_of_the_world_and_walks_on_when_handed_back():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[15, 1]], [[15, 5]], radius=0.3)
    sim.drive(ids, [0.0, -1.0])  # south, off the map
    for _ in range(12):
        sim.step()
    assert np.allclose(sim.positions[0], [15, 0.3])  # its body against the bound
    sim.drive(ids, None)
    while sim.time < 20 and not sim.arrived[0]:
        sim.step()
    assert sim.arrived[0]


def test_agents_in_touch_elsewhere_do_not_stop_a_new_one_coming_in():
    alley = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([0, 0.62], [5, 10])])  # 0.62 m wide, 5 m deep
    sim = rvo.Simulator(alley, guidance="direct", remove_on_arrival=False)
    sim.add_agents([[0.3, 0.3]], [[0.3, 0.3]], radius=0.25)  # standing at the alley's dead end
    player = sim.add_agents([[2.0, 0.31]], [[2.0, 0.31]], radius=0.3)
    sim.drive(player, [-1.0, 0.0])
    for _ in range(8):
        sim.step()  # the player presses it into the dead end
    assert np.linalg.norm(sim.positions[0] - sim.positions[1]) < 0.5
    sim.add_agents([[17, 8]], [[8, 8]])  # far from both
    with pytest.raises(ValueError, match=r"agents [01] and 3 \(being added\) start overlapped"):
        sim.add_agents([sim.positions[1] + [0.3, 0.0]], [[8, 8]])  # on the player


def test_drive_refuses_an_agent_given_twice_with_one_velocity_each():
    sim = _sim()
    with pytest.raises(ValueError, match="drive: agent 1 is given twice"):
        sim.drive([1, 1], [[1, 0], [0, 1]])


def test_the_crowd_walks_on_when_the_last_obstacle_of_the_scene_is_taken_out():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))  # auto guidance: straight, then a field, then straight
    sim.add_agents([[2, 3], [2, 7]], [[18, 3], [18, 7]])
    wall = sim.add_obstacle(cm.Box([9, 4], [11, 6]))
    for _ in range(10):
        sim.step()
    sim.remove_obstacle(wall)
    while sim.time < 30 and not sim.arrived.all():
        sim.step()  # every replan_s the congestion-aware field was re-solved: none is left to re-solve
    assert sim.arrived.all()


def test_walkers_given_a_goal_each_in_one_call_find_their_own_goals_round_the_buildings():
    # more goal points than fields: nearby goals share a field, so each walker is led
    # towards its own part of the square, and at the end of it, its own goal behind a
    # building, along its own goal's field (one field of all the goals led each to the
    # nearest goal of anyone: 24 of the 60 had not arrived after 40 s)
    scene = cm.Scene(bounds=([0, 0], [40, 30]), obstacles=[
        cm.Circle([20, 15], 2.5), cm.Box([4, 4], [10, 9]), cm.Box([30, 4], [36, 9]), cm.Box([4, 21], [10, 26]),
        cm.Box([30, 21], [36, 26])])
    rng = np.random.default_rng(0)
    spots = []
    while len(spots) < 120:
        q = rng.uniform([1, 1], [39, 29])
        if scene.static_obstacle_distance(q[None])[0] > 0.5 and all(np.linalg.norm(q - r) > 0.8 for r in spots):
            spots.append(q)
    starts, goals = np.array(spots[:60]), np.array(spots[60:])
    sim = rvo.Simulator(scene, rng=np.random.default_rng(0))
    with pytest.warns(UserWarning, match="60 different goal points in one call share 16 guidance fields"):
        sim.add_agents(starts, goals, radius=0.25)
    while sim.time < 40 and not sim.arrived.all():
        sim.step()
    assert sim.arrived.all(), int(sim.arrived.sum())


def test_a_walker_whose_group_field_ends_at_anothers_goal_goes_on_along_its_own():
    # 17 goal points: the two nearest each other, either side of a building, share a field;
    # the walker bound for the south side starts in the north, where that field ends
    scene = cm.Scene(bounds=([0, 0], [100, 100]), obstacles=[cm.Box([40, 40], [60, 50])])
    far = [[x, y] for x in (5, 22, 78, 95) for y in (5, 22, 78, 95)][:15]
    goals = np.array(far + [[50, 51.0], [50, 39.0]])
    starts = goals + [0.0, 0.0]
    starts[-1] = [50, 56]  # bound for (50, 39), south of the building, from the north
    starts[-2] = [50, 60]
    sim = rvo.Simulator(scene, rng=np.random.default_rng(0))
    with pytest.warns(UserWarning, match="17 different goal points in one call share 16 guidance fields"):
        ids = sim.add_agents(starts, goals, radius=0.3)
    shared = sim.field_of[ids[-1]]
    assert sim.field_of[ids[-2]] == shared
    while sim.time < 60 and not sim.arrived[ids[-1]]:
        sim.step()
    assert sim.arrived[ids[-1]] and sim.field_of[ids[-1]] != shared, "round the building to its own goal"


def test_agents_added_mid_run_solve_only_their_new_goals_fields_unless_wider():
    sim = rvo.Simulator(_room_with_door(), rng=np.random.default_rng(0))
    exit_area = cm.Rect([17, 1], [19, 9])
    sim.add_agents([[2, 2], [2, 8]], exit_area.center, goal_region=exit_area, radius=0.25)
    sim.step()
    fields = sim._fields
    sim.add_agents([[3, 5]], exit_area.center, goal_region=exit_area, radius=0.25)  # a known goal: nothing solved
    sim.add_agents([[4, 5]], [[16, 3]], radius=0.2)  # a new goal: its field alone
    sim.step()
    assert sim._fields is fields and len(sim._exact) == 2
    sim.add_agents([[5, 8]], [[16, 7]], radius=0.4)  # wider: every field again, with its clearance
    sim.step()
    assert sim._fields is not fields and len(sim._exact) == 3
    while sim.time < 40 and not sim.arrived.all():
        sim.step()
    assert sim.arrived.all()


def test_a_walker_whose_own_goal_a_new_obstacle_covers_steps_on_without_its_own_field():
    scene = cm.Scene(bounds=([0, 0], [100, 100]), obstacles=[cm.Box([40, 40], [60, 50])])
    far = [[x, y] for x in (5, 22, 78, 95) for y in (5, 22, 78, 95)][:15]
    goals = np.array(far + [[50, 51.0], [50, 39.0]])
    starts = goals + [0.0, 0.0]
    starts[-1], starts[-2] = [50, 56], [50, 60]
    sim = rvo.Simulator(scene, rng=np.random.default_rng(0))
    with pytest.warns(UserWarning):
        ids = sim.add_agents(starts, goals, radius=0.3)
    sim.add_obstacle(cm.Box([48, 37], [52, 40]))  # over the south goal: the group's field still ends north
    for _ in range(80):
        sim.step()  # the walker bound south comes to the north goal and finds no field of its own
    assert sim.active[ids[-1]] and not sim.arrived[ids[-1]]


def test_an_obstacle_call_solves_again_only_the_fields_in_use_and_the_others_when_next_used():
    sim = rvo.Simulator(_room_with_door(), rng=np.random.default_rng(0))
    early, late = cm.Rect([17, 1], [19, 3]), cm.Rect([17, 7], [19, 9])
    sim.add_agents([[2, 2]], early.center, goal_region=early)
    sim.add_agents([[2, 8]], late.center, goal_region=late)
    sim.remove_agents([0])  # nobody walks to the early region any more
    sim.step()
    assert sim._solved.all()
    bar = sim.add_obstacle(cm.Box([17.5, 1.5], [18.5, 2.5]))  # on the unused region: only the field in use is solved
    assert list(sim._solved) == [False, True]
    sim.step()
    sim.remove_obstacle(bar)
    ids = sim.add_agents([[3, 5]], early.center, goal_region=early)  # in use again: solved at the rebuild
    sim.step()
    assert sim._solved.all()
    while sim.time < 40 and not sim.arrived[ids].all():
        sim.step()
    assert sim.arrived[ids].all()


def test_a_goal_an_obstacle_covered_while_nobody_walked_to_it_is_refused_when_given_again():
    sim = rvo.Simulator(_room_with_door(), rng=np.random.default_rng(0))
    spot = [18.0, 2.9]  # free now; inside the box put in below
    sim.add_agents([[2, 2]], spot)
    sim.add_agents([[2, 8]], [18, 8])
    sim.remove_agents([0])
    sim.step()
    sim.add_obstacle(cm.Box([17, 1], [19, 3]))  # over the goal nobody walks to now: accepted
    with pytest.raises(ValueError, match=r"goals: \[18.0, 2.9\] .* lies inside an obstacle"):
        sim.set_goals([1], spot)
    assert np.allclose(sim.goals[1], [18, 8])


def test_a_goal_point_no_body_can_stand_on_is_moved_where_it_fits_with_a_warning():
    # 0.1 m from a box, 0.02 m from the scene's edge: a body of radius 0.25 reaches neither,
    # and eq. (3) stood such an agent metres short of it for good
    sim = rvo.Simulator(_room_with_door(), rng=np.random.default_rng(0))
    sim.add_obstacle(cm.Box([17, 1], [19, 3]))
    with pytest.warns(UserWarning, match=r"goals: the goal point \[18.0, 3.1\], of the 1st of 1 agents "
                                         r"\(radius 0.25 m\) lies closer to a wall .*to \[18.0, 3.27\]"):
        ids = sim.add_agents([[2, 8]], [18.0, 3.1], radius=0.25)
    np.testing.assert_allclose(sim.goals[ids[0]], [18.0, 3.27])
    lo, hi = sim.scene.lower, sim.scene.upper
    with pytest.warns(UserWarning, match="goals: the goal point"):
        sim.set_goals(ids, [hi[0] - 0.02, 8.0])
    np.testing.assert_allclose(sim.goals[ids[0]], [hi[0] - 0.27, 8.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.set_goals(ids, [hi[0] - 0.25, 8.0])  # a body just fits: kept as given
    assert sim.goals[ids[0], 0] == hi[0] - 0.25


def test_an_agent_sent_to_a_goal_walled_in_is_warned_of_once_at_the_next_step():
    scene = cm.Scene(bounds=([0, 0], [30, 20]), obstacles=[
        cm.Box([20, 10], [24, 10.5]), cm.Box([20, 13.5], [24, 14]), cm.Box([20, 10], [20.5, 14]),
        cm.Box([23.5, 10], [24, 14])])  # a closed pocket round (22, 12)
    sim = rvo.Simulator(scene, time_step=0.25)
    ids = sim.add_agents([[2, 2], [2, 6]], [[28, 2], [28, 6]], radius=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.step()  # both goals reachable: nothing to say
    sim.set_goals([ids[1]], [22, 12])
    with pytest.warns(UserWarning, match=r"agent 1 cannot reach its goal: obstacles standing now cut the way"):
        sim.step()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.step()  # said once
    assert sim.unreachable().tolist() == [False, True]


@pytest.mark.parametrize("kwargs,name", [({"time_step": "0.1"}, "time_step"), ({"time_step": None}, "time_step"),
                                         ({"patience": [2.0]}, "patience"), ({"replan_s": True}, "replan_s"),
                                         ({"counterflow": "20"}, "counterflow")])
def test_a_setting_that_is_no_number_is_refused_naming_it(kwargs, name):
    # numpy's isfinite refused a string with a TypeError that named no argument
    with pytest.raises(ValueError, match=rf"^{name} must be .*, got {re.escape(repr(next(iter(kwargs.values()))))}$"):
        rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])), **kwargs)


def test_agents_due_at_one_entrance_come_in_one_at_a_time_while_another_entrance_is_blocked():
    # three due at once, the first still blocked at its own entrance: the two sharing the other
    # entrance must not both come in (they would walk on, one on top of the other)
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])), time_step=1 / 30)
    b1 = sim.add_agents([[2, 2]], [[18, 2]])
    sim.drive(b1, [0.0, 0.0])  # stands on entrance 1
    b2 = sim.add_agents([[2, 7]], [[18, 7]])
    sim.drive(b2, [0.0, 0.0])  # stands on entrance 2
    sim.add_agents([[2, 2]], [[18, 2]], enter_at=0.0)
    a = sim.add_agents([[2, 7]], [[18, 7]], enter_at=0.0)
    b = sim.add_agents([[2, 7]], [[18, 7]], enter_at=0.0)
    sim.step()
    sim.remove_agents(b2)
    sim.step()
    assert sim.active[a[0]] != sim.active[b[0]]  # one of them, the other still waiting
    for _ in range(60):
        sim.step()
        on = np.flatnonzero(sim.active)
        gaps = np.linalg.norm(sim.positions[on, None] - sim.positions[None, on], axis=2) + 9 * np.eye(len(on))
        assert gaps.min() >= 0.5 - 1e-9


@pytest.mark.parametrize("region, hint", [
    (cm.Box([36, 1], [39, 9]), "a goal rectangle is crowdmotion.Rect"),
    (cm.Circle([37, 5], 2.0), "a goal disc is crowdmotion.Disc"),
    ([[36, 1], [39, 9]], ""),
])
def test_an_obstacle_shape_or_a_list_given_as_goal_region_is_refused_and_the_crowd_walks_on(region, hint):
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 10]), obstacles=[cm.Box([20, 0], [21, 6])]))
    sim.add_agents([[2, 8]], [[38, 8]])
    for call in (lambda: sim.add_agents([[2, 6]], [[38, 8]], goal_region=region),
                 lambda: sim.set_goals([0], [[37, 5]], goal_region=region)):
        with pytest.raises(ValueError, match=r"goal_region: a Rect, Disc or Points region is needed, got .*"
                                             + re.escape(hint)):
            call()
    assert sim.n_agents == 1 and np.array_equal(sim.goals[0], [38, 8])
    sim.step()  # and it steps on


def test_a_newcomer_waits_while_one_leaving_on_its_spot_is_still_drawn_there():
    # an exit that is also an entrance: the frame that shows one arriving (and leaving) at
    # the spot must not show a newcomer let in on top of it
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    leaving = sim.add_agents([[5.0, 5.0]], [[5.2, 5.0]])  # within arrival_radius: leaves in the first step
    newcomer = sim.add_agents([[5.1, 5.0]], [[15, 5]], enter_at=0.0)
    sim.step()
    assert sim.present[leaving[0]] and not sim.active[leaving[0]]  # drawn in this frame, then gone
    assert not sim.active[newcomer[0]]
    sim.step()
    assert sim.active[newcomer[0]]


@pytest.mark.parametrize("dt", [1 / 60, 1 / 30, 0.25])
def test_a_walker_that_stays_at_its_goal_brakes_and_stops_on_it(dt):
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [30, 20])), time_step=dt, remove_on_arrival=False)
    sim.add_agents([[5, 15]], [[8, 15]])  # 3 m east, nobody else
    xs = []
    for _ in range(int(round(20 / dt))):
        sim.step()
        xs.append(sim.positions[0, 0])
    xs = np.array(xs)
    assert xs.max() - 8.0 < 0.2  # not a metre past it
    assert np.abs(np.diff(xs[int(round(10 / dt)):])).sum() < 1e-3  # and no pacing to and fro after


def test_prepare_solves_the_guidance_fields_before_the_first_step_and_changes_no_step():
    scene = cm.Scene(bounds=([0, 0], [40, 20]), obstacles=[cm.Box([18, 0], [20, 14])])

    def crowd():
        sim = rvo.Simulator(scene, rng=np.random.default_rng(0))
        sim.add_agents([[2, 3], [2, 6], [3, 9]], [[36, 5]] * 3)
        return sim

    plain, prepared = crowd(), crowd()
    prepared.prepare()
    assert prepared._fields is not None and not prepared._fields_stale  # solved: the first step need not
    for _ in range(40):
        plain.step()
        prepared.step()
    np.testing.assert_array_equal(plain.positions, prepared.positions)


def test_goal_points_given_away_from_their_goal_region_are_told_of():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 10])))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.add_agents([[1, 1]], [[38, 5]], goal_region=cm.Rect([36, 1], [39, 9]))  # inside: nothing to say
    with pytest.warns(UserWarning, match=r"add_agents: 1 of the 1 goal points lie outside their goal_region"):
        sim.add_agents([[1, 3]], [[20, 5]], goal_region=cm.Rect([36, 1], [39, 9]))
    with pytest.warns(UserWarning, match=r"set_goals: 2 of the 2 goal points lie outside"):
        sim.set_goals([0, 1], [[5, 5], [6, 5]], goal_region=cm.Rect([36, 1], [39, 9]))


def test_live_facing_turns_at_most_the_max_turn_rate_per_step_in_a_doorway_crowd_at_60_hz():
    # the velocities of a crowd pressing through a 1.2 m door snap round within a frame
    # (a reversal in 16 ms); a character's root set from sim.facing turns smoothly
    from crowdmotion.facing import MAX_TURN_RATE, wrap

    dt = 1 / 60
    walls = [cm.Box([14.5, 0], [15.5, 9.4]), cm.Box([14.5, 10.6], [15.5, 20])]
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [30, 20]), obstacles=walls), time_step=dt,
                        rng=np.random.default_rng(0))
    xs, ys = np.meshgrid(np.arange(8, 14, 0.8), np.arange(6, 14, 0.8))
    exit_area = cm.Rect([26, 6], [29, 14])
    sim.add_agents(np.c_[xs.ravel(), ys.ravel()][:60], exit_area.center, goal_region=exit_area,
                   arrive_anywhere=True, radius=0.25)
    assert np.allclose(np.cos(sim.facing), 1.0, atol=0.3), "each faces the exit (to +x) before it moves"
    facing, headings, stepped = [sim.facing.copy()], [], []
    for _ in range(600):
        stepped.append(sim.active.copy())
        sim.step()
        facing.append(sim.facing.copy())
        headings.append(np.arctan2(sim.velocities[:, 1], sim.velocities[:, 0]))
    stepped = np.array(stepped)
    turn = np.abs(wrap(np.diff(np.array(facing), axis=0)))
    assert turn.max() <= MAX_TURN_RATE * dt + 1e-9
    snaps = np.abs(wrap(np.diff(np.array(headings), axis=0)))[stepped[1:] & stepped[:-1]]
    assert (snaps > np.pi / 4).sum() > 10, "the velocities themselves do snap round"
    with pytest.raises(ValueError):
        sim.facing[0] = 1.0  # read-only


def test_live_facing_converges_to_the_walking_direction_and_holds_while_standing():
    from crowdmotion.facing import MAX_TURN_RATE, wrap

    dt = 1 / 60
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 10])), time_step=dt, remove_on_arrival=False)
    ids = sim.add_agents([[12, 5], [5, 5]], [[35, 5], [5, 5]])  # the second stands on its goal
    assert sim.facing[0] == pytest.approx(0.0) and sim.facing[1] == 0.0
    for _ in range(120):
        sim.step()
    sim.set_goals(ids[:1], [8, 5])  # turn back: west
    turns, walks_west, faces_west = [], None, None
    for k in range(1800):
        if sim.arrived[0]:
            break
        before = sim.facing[0]
        sim.step()
        turns.append(abs(wrap(sim.facing[0] - before)))
        if walks_west is None and sim.velocities[0, 0] < -0.25 * 1.3:  # it stops (comfortably), then walks back
            walks_west = k
        heading = np.arctan2(sim.velocities[0, 1], sim.velocities[0, 0])
        if walks_west is not None and faces_west is None and abs(wrap(sim.facing[0] - heading)) < 1e-9:
            faces_west = k  # on the walking direction itself
    assert max(turns) <= MAX_TURN_RATE * dt + 1e-9
    # once it walks west, it faces the way it walks within a half turn's time at the max turn rate
    assert walks_west is not None and faces_west is not None
    assert (faces_west - walks_west + 1) * dt <= np.pi / MAX_TURN_RATE + 0.05
    for _ in range(240):  # it walks on to its goal point (a side step: it faces it), and stops
        sim.step()
    held, speeds = sim.facing[0], []
    for _ in range(60):
        sim.step()
        speeds.append(np.linalg.norm(sim.velocities[0]))
    assert sim.arrived[0] and max(speeds) < 0.25 * 1.3, "it stands"
    assert sim.facing[0] == held, "standing at its goal, it holds its facing"
    assert sim.facing[1] == 0.0, "one that never moved holds +x"


def test_a_time_step_above_the_stall_step_warns_naming_the_value_and_one_above_the_scenarios_limit_is_refused():
    from crowdmotion.rvo.params import MAX_TIME_STEP_S, STALL_TIME_STEP_S, RVOParams

    scene = cm.Scene(bounds=([0, 0], [10, 10]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rvo.Simulator(scene, time_step=STALL_TIME_STEP_S)  # the largest step that still arrives as at 0.25 s
    with pytest.warns(UserWarning, match=r"^time_step 2\.0 s is above 0\.6 s: .*stall"):
        rvo.Simulator(scene, time_step=2.0)
    # as the scenario's [rvo] time_step: up to MAX_TIME_STEP_S, no further
    RVOParams(time_step=MAX_TIME_STEP_S)
    with pytest.raises(ValueError, match=r"time_step must be a positive number of seconds, at most 10, got 10\.5"):
        rvo.Simulator(scene, time_step=10.5)


def test_sim_time_is_steps_times_the_time_step_not_a_running_sum_that_drifts():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])), time_step=0.05)
    for _ in range(709):
        sim.step()
    assert sim.time == 709 * 0.05 == 35.45  # a running sum of 0.05 drifts to 35.450000000000124
    with pytest.raises(AttributeError):
        sim.time = 0.0


@pytest.mark.parametrize("positions", [[], np.zeros((0, 2))])
def test_an_empty_wave_adds_nobody_and_returns_an_empty_id_array(positions):
    sim = _sim()
    ids = sim.add_agents(positions, [18, 18])
    assert ids.dtype == np.int64 and ids.shape == (0,) and sim.n_agents == 3
    sim.step()
    assert sim.n_agents == 3 and len(sim.facing) == 3
    with pytest.raises(ValueError, match="goals"):
        sim.add_agents(positions, [np.nan, 18])  # the goal is still checked
    with pytest.raises(ValueError, match=r"positions must be an \(N, 2\) array"):
        sim.add_agents(np.zeros((2, 0)), [18, 18])


def test_goals_of_shape_1_by_2_are_one_goal_for_every_agent_added_or_sent_on():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20])), rng=np.random.default_rng(0))
    goals = np.array([[18.0, 10.0], [18.0, 4.0]])
    ids = sim.add_agents([[2, 2], [2, 6], [2, 10]], goals[:1])
    assert np.array_equal(sim.goals, np.tile([18.0, 10.0], (3, 1)))
    sim.set_goals(ids, goals[1:])
    assert np.array_equal(sim.goals, np.tile([18.0, 4.0], (3, 1)))
    with pytest.raises(ValueError, match=r"goals must be \(2,\) or \(3, 2\), got shape \(2, 2\)"):
        sim.add_agents([[4, 2], [4, 6], [4, 10]], goals)


@pytest.mark.parametrize("call", ["remove_obstacle", "move_obstacle"])
def test_a_float_obstacle_index_is_refused_as_not_an_int(call):
    boxes = [cm.Box([5, 5], [6, 6]), cm.Box([9, 9], [10, 10])]
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20]), obstacles=boxes))
    args = (1.0,) if call == "remove_obstacle" else (1.0, (0, 1))
    with pytest.raises(ValueError, match=rf"^{call}: the obstacle index must be an int \(add_obstacle returns it\), "
                                         r"got 1\.0 \(float\)$"):
        getattr(sim, call)(*args)
    with pytest.raises(ValueError, match=rf"^{call}: no obstacle 2 \(indices run from 0 to 1\)$"):
        getattr(sim, call)(*((2,) + args[1:]))


def test_add_agents_refusing_an_agent_that_does_not_fit_does_not_first_warn_that_it_moved_its_goal():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [30, 20])))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning would raise here instead of the refusal
        with pytest.raises(ValueError, match="does not fit inside the scene bounds"):
            sim.add_agents([[15, 17]], [[25, 17]], radius=5)
    assert sim.n_agents == 0
    with pytest.warns(UserWarning, match="Moved the least way"):  # one that fits is still told
        sim.add_agents([[15, 10]], [[25, 17]], radius=5)


# ---- people who have arrived and stay: the others pass them as standing obstacles -----------------
#: RiMEA test 5's room (x 0-5, y 0-8, the 1 m exit at x 2-3) and its ten places
_ROOM_PLACES = [(1.0, 1.0), (2.5, 1.0), (4.0, 1.0), (1.0, 3.0), (2.5, 3.0), (4.0, 3.0), (1.0, 5.0), (2.5, 5.0),
                (4.0, 5.0), (2.5, 6.5)]


def _room_waiting(walker: int, **params):
    """RiMEA 5's room: ``walker`` due at 1 s, the other nine waiting 100 s; stepped until
    the walker is out or 30 s. (simulator, places, the others' ids, frames, present)"""
    from crowdmotion.stages import Leave, Wait

    scene = cm.Scene(bounds=([0, 0], [5, 11]), obstacles=[cm.Box([0, 8], [2, 8.3]), cm.Box([3, 8], [5, 8.3])])
    sim = rvo.Simulator(scene, rng=np.random.default_rng(0), remove_on_arrival=False, **params)
    places = np.array(_ROOM_PLACES)
    ids = sim.add_agents(places, places)
    outside = Leave(cm.groups.Rect([0.5, 9.5], [4.5, 11.0]))
    sim.set_route(ids[[walker]], [Wait(1.0), outside])
    others = np.delete(ids, walker)
    sim.set_route(others, [Wait(100.0), outside])
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.present[walker] and sim.time < 30.0:
        sim.step()
        _record(sim, frames, present)
    return sim, places, others, frames, present


@pytest.mark.parametrize("walker", [1, 7])  # three waiting in its way to the exit / one waiting before the exit
def test_a_person_whose_wait_is_over_walks_round_people_still_waiting_in_its_way(walker):
    sim, places, others, frames, present = _room_waiting(walker)
    # 8.5 m at most to the exit's far side: 6.4 s at 1.33 m/s; standing behind them, it would wait 100 s
    assert not sim.present[walker] and sim.time < 12.0, (sim.time, sim.positions[walker])
    shoved = np.linalg.norm(np.array(frames)[:, others] - places[others], axis=2)
    assert shoved.max() < 0.3, "those waiting step aside at most a little for it"
    assert np.linalg.norm(sim.positions[others] - places[others], axis=1).max() < 0.05, "and are back in place"
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    audit = collision_audit(traj, sim.scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0, audit.events[:3]


def test_with_pass_standing_off_those_waiting_count_as_eq3_has_them_and_hold_the_walker():
    sim, *_ = _room_waiting(1, pass_standing=False, held_horizon=False)
    assert sim.present[1], "eq. (3)'s reciprocal rule: every line through the gaps meets someone within 4 m"


def test_one_waiting_in_the_middle_of_a_narrow_corridor_steps_aside_for_a_walker_held_behind_it_and_returns():
    # 1.4 m wide: 0.45 m either side of the one waiting, too little for a 0.5 m body
    from crowdmotion.stages import Leave, Wait

    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 1.4])), rng=np.random.default_rng(0))
    place = np.array([10.0, 0.7])
    waiting = sim.add_agents(place[None], place[None])
    sim.set_route(waiting, [Wait(60.0), Leave(cm.groups.Rect([19.0, 0.2], [19.9, 1.2]))])
    walker = sim.add_agents([[1.0, 0.7]], [[19.5, 0.7]])
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.time < 40.0:
        sim.step()
        _record(sim, frames, present)
    assert not sim.present[walker[0]], "the walker got past (15 s of free walking)"
    moved = np.linalg.norm(np.array(frames)[:, waiting[0]] - place, axis=1)
    assert 0.05 < moved.max() < 0.5, "it stepped aside, no farther than the wall lets it"
    assert moved[-1] < 0.05, "and is back in its place"
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    audit = collision_audit(traj, sim.scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0, audit.events[:3]


def test_the_live_simulator_and_a_scenarios_rvo_table_have_the_same_defaults():
    # each default is written twice (Simulator's keywords, RVOParams' fields): a live
    # game and a scenario file must walk alike when neither sets it
    import inspect

    from crowdmotion.rvo.params import RVOParams

    keywords = inspect.signature(rvo.Simulator.__init__).parameters
    shared = [k for k in keywords if k in RVOParams.model_fields]
    assert "comfort_accel" in shared and len(shared) >= 15
    assert {k: keywords[k].default for k in shared} == {k: RVOParams.model_fields[k].default for k in shared}
