"""RVO crowds: the antipodal circle, head-on pairs, obstacles, guidance, determinism, bad input."""

import warnings

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.metrics import collision_audit
from crowdmotion.trajectories import Trajectories


def _run(sim, max_steps=3000):
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.active.any() and sim.steps < max_steps:
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())
    return Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))


def _circle(seed, n=200, radius=40.0):
    ang = 2 * np.pi * np.arange(n) / n
    pos = radius * np.c_[np.cos(ang), np.sin(ang)]
    scene = cm.Scene(bounds=([-45, -45], [45, 45]))
    sim = rvo.Simulator(scene, time_step=0.25, rng=np.random.default_rng(seed))
    sim.add_agents(pos, -pos, radius=0.5, max_speed=1.5, pref_speed=1.3)
    return scene, sim


@pytest.fixture(scope="module")
def circle_runs():
    out = []
    for seed in (1, 1, 2):
        scene, sim = _circle(seed)
        out.append((scene, sim, _run(sim)))
    return out


def test_antipodal_circle_all_arrive_without_contact(circle_runs):
    scene, sim, traj = circle_runs[0]
    assert sim.arrived.all()
    report = collision_audit(traj, scene, tolerance=0.01 * 0.5)
    assert report.agent_agent == 0 and report.agent_obstacle == 0
    # and really no contact at all, not only within the tolerance
    assert collision_audit(traj, scene).agent_agent == 0
    # everyone crossed the centre: each walked at least the 80 m diameter
    assert np.all(np.linalg.norm(traj.positions[-1] - traj.positions[0], axis=1) > 79)


def test_same_seed_same_paths_other_seed_other_paths(circle_runs):
    (_, _, a), (_, _, b), (_, _, c) = circle_runs
    assert np.array_equal(a.positions, b.positions)
    assert a.positions.shape != c.positions.shape or not np.array_equal(a.positions, c.positions)


def test_two_agents_head_on_pass_without_touching():
    scene = cm.Scene(bounds=([-10, -5], [10, 5]))
    sim = rvo.Simulator(scene, time_step=0.1, rng=np.random.default_rng(0))
    sim.add_agents([[-6, 0], [6, 0]], [[6, 0], [-6, 0]], radius=0.4)
    traj = _run(sim, 1000)
    assert sim.arrived.all()
    assert collision_audit(traj, scene).agent_agent == 0
    a, b = traj.positions[:, 0], traj.positions[:, 1]
    both = traj.active.all(axis=1)
    gap = np.linalg.norm(a[both] - b[both], axis=1)
    assert gap.min() >= 0.8 - 1e-9
    # they passed each other (swapped sides), sidestepping rather than stopping
    assert a[-1, 0] > 5 and b[-1, 0] < -5
    assert np.abs(traj.positions[:, :, 1]).max() > 0.2


def test_obstacles_of_every_shape_are_never_penetrated():
    scene = cm.Scene(bounds=([0, 0], [30, 20]), obstacles=[
        cm.Circle([10, 10], 2.0), cm.Box([15, 3], [17, 9]), cm.Polygon([[20, 12], [24, 14], [21, 17]]),
        cm.Circle([13.5, 18], 0.8, path=([0, 40], [[13.5, 18], [13.5, 2]])),
    ])
    rng = np.random.default_rng(3)
    sim = rvo.Simulator(scene, time_step=0.2, rng=rng)
    ys = np.linspace(2, 18, 12)
    sim.add_agents(np.c_[np.full(12, 2.0), ys], np.c_[np.full(12, 28.0), ys[::-1]], radius=0.3)
    sim.add_agents(np.c_[np.full(12, 28.0), ys], np.c_[np.full(12, 2.0), ys], radius=0.3)
    traj = _run(sim, 2000)
    report = collision_audit(traj, scene)
    assert report.agent_obstacle == 0 and report.agent_agent == 0
    assert sim.arrived.mean() >= 0.95


def test_guidance_field_routes_round_a_wall_that_blocks_direct_walking():
    # a pocket: a wall across most of the street with a lip that traps anyone walking straight
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([9, 0], [10, 8.5]), cm.Box([6, 7.5], [9, 8.5])])
    out = {}
    for guidance in ("direct", "field"):
        sim = rvo.Simulator(scene, time_step=0.25, guidance=guidance, rng=np.random.default_rng(0))
        sim.add_agents([[3, 3], [3, 5], [4, 2]], [[17, 3], [17, 5], [16, 2]], radius=0.3)
        traj = _run(sim, 600)
        out[guidance] = sim.arrived.mean()
        assert collision_audit(traj, scene).clean
    assert out["field"] == 1.0 and out["direct"] < 1.0


def test_agents_may_stay_at_their_goal():
    scene = cm.Scene(bounds=([0, 0], [10, 10]))
    sim = rvo.Simulator(scene, remove_on_arrival=False)
    sim.add_agents([[1, 1]], [[3, 1]])
    for _ in range(40):
        sim.step()
    assert sim.arrived.all() and sim.active.all()
    assert np.linalg.norm(sim.positions[0] - [3, 1]) <= 0.5


@pytest.mark.parametrize("kwargs,words", [
    ({"radius": -0.2}, "radius must be > 0, got -0.2 for the 1st of the 2 agents given"),
    ({"max_speed": float("nan")}, "max_speed"),
    ({"pref_speed": 2.0, "max_speed": 1.0}, "pref_speed 2.0 exceeds max_speed 1.0"),
    ({"personality": "Z-"}, "unknown personality trait 'Z-'"),
    ({"personality": [0, 0, 0, 0, 2]}, "ψN must lie in [-1, 1]"),
    ({"personality": "O+", "safety": 2.0}, "give either a personality or those parameters"),
    ({"samples": 2.5}, "samples must be > 0 whole"),
    ({"samples": 1e8}, "samples must be > 0 whole and at most 10000, got 100000000.0"),
    ({"max_neighbors": [5, 20_000]}, "max_neighbors must be >= 0 whole and at most 10000, got 20000.0 for the 2nd of the 2 agents given"),
])
def test_bad_agent_parameters_are_named(kwargs, words):
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])))
    with pytest.raises(ValueError) as e:
        sim.add_agents([[1, 1], [3, 3]], [[9, 9], [8, 8]], **kwargs)
    assert words in str(e.value)
    assert sim.n_agents == 0


def test_overlapping_or_buried_starts_are_refused():
    scene = cm.Scene(bounds=([0, 0], [10, 10]), obstacles=[cm.Circle([5, 5], 1.0)])
    sim = rvo.Simulator(scene)
    with pytest.raises(ValueError, match=r"agents 0 \(being added\) and 1 \(being added\) start overlapped"):
        sim.add_agents([[1, 1], [1.3, 1]], [[9, 9], [8, 8]], radius=0.25)
    with pytest.raises(ValueError, match="agent 0 at .* starts inside an obstacle"):
        sim.add_agents([[5.5, 5]], [[9, 9]])


def test_personality_sets_table4_parameters_per_agent():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])))
    sim.add_agents([[1, 1], [3, 3]], [[9, 9], [8, 8]], personality="C+")
    sim.add_agents([[5, 1]], [[5, 9]], personality=[0, 0, 0, 0, -1])
    assert sim.params["max_neighbors"].tolist() == [20, 20, 5]
    assert sim.params["neighbor_dist"].tolist() == [20.0, 20.0, 5.0]
    assert sim.params["samples"].tolist() == [50, 50, 25]
    assert sim.params["safety"].tolist() == [1.0, 1.0, 7.5]


def test_a_groups_own_samples_obey_the_rvo_bound_in_the_python_api_too():
    group = cm.Group("g", 4, spawn=cm.Rect([1, 1], [4, 4]), goal=cm.Points([[9, 9]]), attributes={"samples": 1e8})
    with pytest.raises(ValueError, match="group 'g'.*samples must be > 0 whole and at most 10000"):
        rvo.simulate(cm.Scene(bounds=([0, 0], [10, 10])), [group])


def _two_exit_hall(assignment: str):
    """A hall (y 6-20) whose wall at y 5-6 has a 2 m exit at x 4-6 and another at x 34-36;
    40 people stand near the left exit; the safe area is the strip below the wall."""
    scene = cm.Scene(bounds=([0, 0], [40, 20]), obstacles=[
        cm.Box([0, 5], [4, 6]), cm.Box([6, 5], [34, 6]), cm.Box([36, 5], [40, 6])])
    group = cm.Group("evacuees", 40, cm.Rect([1, 7], [14, 12]), cm.Rect([0.5, 0.5], [39.5, 4.0]), radius=0.25)
    return rvo.run(scene, [group], rvo.RVOParams(goal_assignment=assignment, max_steps=1200), np.random.default_rng(4))


def test_evacuees_that_arrive_anywhere_in_the_safe_area_take_the_nearest_exit_and_are_out_sooner():
    near, spread = _two_exit_hall("nearest"), _two_exit_hall("sample")
    for r in (near, spread):
        assert r.simulator.arrived.all()
    crossed_right = lambda r: (r.trajectories.positions[..., 0] > 30).any(axis=0)  # noqa: E731
    assert not crossed_right(near).any(), "nobody walked to the far exit"
    assert near.simulator.arrival_time.max() < spread.simulator.arrival_time.max()
    assert (near.simulator.positions[:, 1] <= 4.0 + 0.5 + 1e-9).all(), "each arrived at the edge of the safe area"


def test_everyone_sent_to_an_exit_strip_along_the_scene_edge_arrives():
    # a goal point drawn in the strip may lie closer to the edge than a body's radius:
    # such an agent used to stop metres short, the wall ahead of its goal costing more
    # than standing (8 of 20 single walkers, 25 of 220 in all, stood for good)
    scene = cm.Scene(bounds=([0, 0], [20, 3]))
    for seed in range(6):
        group = cm.Group("walkers", 5, cm.Rect([0.5, 0.5], [4, 2.5]), cm.Rect([19.5, 0], [20, 3]), radius=0.25)
        r = rvo.run(scene, [group], rvo.RVOParams(max_steps=240), np.random.default_rng(seed))
        assert r.simulator.arrived.all(), f"seed {seed}: {int((~r.simulator.arrived).sum())} never arrived"
        goals = r.simulator.goals
        assert (goals[:, 0] <= 20 - 0.25).all() and (goals[:, 1] >= 0.25).all() and (goals[:, 1] <= 3 - 0.25).all()


def test_arrive_anywhere_needs_a_rect_or_disc_goal_region():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])))
    with pytest.raises(ValueError, match="arrive_anywhere needs a Rect or Disc goal_region"):
        sim.add_agents([[1, 1]], [5, 5], arrive_anywhere=True)


def _door_crowd(**params):
    """60 walkers pressing through a 1 m door: stop and go at the door's mouth."""
    from crowdmotion.rvo.simulation import run

    scene = cm.Scene(bounds=([0, 0], [12, 12]), obstacles=[cm.Box([0, 6], [5.5, 6.3]), cm.Box([6.5, 6], [12, 6.3])])
    group = cm.Group("crowd", 60, spawn=cm.Rect([1, 0.5], [11, 5]), goal=cm.Rect([4, 9], [8, 11.5]), radius=0.25,
                     pref_speed=1.3, max_speed=1.5)
    return scene, run(scene, [group], rvo.RVOParams(**params), np.random.default_rng(3))


def test_a_run_is_relaxed_for_characters_keeping_the_simulated_steps_beside_it():
    from crowdmotion.metrics import root_motion

    scene, relaxed = _door_crowd()
    _, plain = _door_crowd(smoothing="none")
    # the same simulation: the steps as simulated are the plain run's frames
    np.testing.assert_array_equal(relaxed.steps.positions, plain.trajectories.positions)
    tr, steps = relaxed.trajectories, relaxed.steps
    assert tr.n_frames == steps.n_frames and tr.dt == steps.dt
    # everyone starts and ends where the simulation has them, and still reaches its goal
    act = tr.active_mask
    first, last = np.argmax(act, axis=0), tr.n_frames - 1 - np.argmax(act[::-1], axis=0)
    ids = np.arange(tr.n_agents)
    np.testing.assert_allclose(tr.positions[first, ids], steps.positions[first, ids], atol=1e-9)
    np.testing.assert_allclose(tr.positions[last, ids], steps.positions[last, ids], atol=1e-9)
    assert relaxed.simulator.arrived.all()
    # as clean as the steps in continuous time, never faster than max_speed
    assert collision_audit(steps, scene).agent_agent == 0
    audit = collision_audit(tr, scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0
    ok = act[:-1] & act[1:]
    assert tr.speed[:-1][ok].max() <= 1.5 + 1e-9
    # the door's stop-and-go, smoothed: the wobble about the 1 s average at least a third less
    wobble = {k: root_motion(t)["deviation_from_1s_average_m"]["p95"] for k, t in (("relaxed", tr), ("steps", steps))}
    assert wobble["relaxed"] < 2 / 3 * wobble["steps"], wobble
    assert tr.metadata["relaxed"]["at"] == "steps" and tr.metadata["relaxed"]["window_s"] == 1.0
    assert 0 <= tr.metadata["relaxed"]["straight_segments"] < 0.05 * tr.metadata["relaxed"]["segments"]
    assert "resampled" not in tr.metadata  # nothing was resampled: a later export's resampling has the key
    assert plain.steps is plain.trajectories and "relaxed" not in plain.trajectories.metadata


def test_params_may_be_a_dict_and_anything_else_is_refused_by_name():
    scene = cm.Scene(bounds=([0, 0], [10, 4]))
    group = cm.Group("a", 2, spawn=cm.Points([[1, 1], [1, 3]]), goal=cm.Points([[9, 1], [9, 3]]))
    traj = rvo.simulate(scene, [group], {"smoothing": None, "time_step": 0.25})
    assert "relaxed" not in traj.metadata and traj.dt == 0.25
    assert rvo.RVOParams(smoothing=None).smoothing == "none"
    with pytest.raises(TypeError, match="params must be an RVOParams or a dict"):
        rvo.simulate(scene, [group], 3)
    with pytest.raises(ValueError, match="smoothing_window"):
        rvo.simulate(scene, [group], {"smoothing_window": -1.0})


def test_each_group_s_time_to_goal_is_the_one_the_run_measured_last_arrivals_included():
    # the run ends at the step the last walker arrives, which leaves it in the last frame:
    # the frames alone would leave it out of its group's mean
    from crowdmotion.builtin import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    street = next(p for p in builtin_scenarios() if p.stem == "rvo_street_C")
    summary = run_scenario(load_scenario(street), progress=False).summary
    measured = summary["time_to_goal_by_group_s"]
    assert summary["arrival_rate"] == 1.0
    assert {g: summary["groups"][g]["time_to_goal_s"] for g in measured} == pytest.approx(measured)


def test_a_personality_and_the_parameters_it_sets_are_not_given_together(tmp_path):
    # a group's own safety beside its personality was dropped without a word; an [rvo] one
    # that no group takes (every group has a personality) changes nothing and says so
    from crowdmotion.scenario import ScenarioError, parse_scenario

    text = """
name = "p"
method = "rvo"
[scene]
bounds = [[0, 0], [20, 6]]
[[groups]]
name = "a"
count = 4
personality = "O+"
spawn = { shape = "rect", lower = [1, 1], upper = [4, 5] }
goal = { shape = "rect", lower = [16, 1], upper = [19, 5] }
"""
    with pytest.raises(ScenarioError, match=r"groups.0\) attributes.safety: the group's personality 'O\+' sets"):
        parse_scenario(text + "attributes = { safety = 1.0 }\n")
    with pytest.warns(UserWarning, match=r"rvo.safety = 2.0 changes nothing here: every group has a personality"):
        parse_scenario(text + "[rvo]\nsafety = 2.0\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_scenario(text + "[rvo]\ntime_step = 0.2\n")  # not one of the four: no word
        parse_scenario(text.replace('personality = "O+"\n', "") + "[rvo]\nsafety = 2.0\n")  # taken


def test_agents_waiting_to_enter_do_not_move_about_unseen():
    # a stream coming in faster than its entrance lets it: the waiting agents' entry points
    # were drawn again while they waited, and their hidden rows jumped about; a spline
    # through them turned and slid them before they appeared
    from crowdmotion.scenario import parse_scenario, run_scenario

    text = """
name = "stream"
method = "rvo"
seed = 3
[scene]
bounds = [[0.0, 0.0], [30.0, 10.0]]
[[groups]]
name = "in"
count = 30
spawn = { shape = "rect", lower = [0.5, 3.0], upper = [2.0, 7.0] }
goal = { shape = "rect", lower = [27.0, 2.0], upper = [29.5, 8.0] }
enter = { rate = 6.0 }
[rvo]
smoothing = "none"
"""
    tr = run_scenario(parse_scenario(text), progress=False).trajectories
    hidden = ~tr.active_mask[1:] & ~tr.active_mask[:-1]
    moves = np.linalg.norm(np.diff(tr.positions, axis=0), axis=-1)
    assert hidden.any() and moves[hidden].max() == 0.0


CORRIDOR_WAIT = """
name = "held_in_a_corridor"
method = "rvo"
seed = 0

[scene]
bounds = [[0.0, 0.0], [20.0, 1.4]]

[[groups]]
name = "waiter"
count = 1
spawn = { shape = "points", points = [[10.0, 0.7]] }
route = [
  { kind = "wait", time = 100.0 },
  { kind = "leave", area = { shape = "rect", lower = [19.0, 0.2], upper = [19.9, 1.2] } },
]

[[groups]]
name = "walker"
count = 1
spawn = { shape = "points", points = [[1.0, 0.7]] }
goal = { shape = "rect", lower = [19.0, 0.2], upper = [19.9, 1.2] }

[rvo]
max_steps = 200
pass_standing = false
"""


def test_a_run_ended_at_its_step_limit_tells_one_held_for_good_from_one_still_waiting():
    # a 1.4 m corridor with one waiting 100 s in its middle (0.45 m either side of it) that
    # does not step aside (pass_standing off): the walker stands behind it for good, the
    # one waiting has its wait to stand out
    from crowdmotion.metrics import headline
    from crowdmotion.scenario import parse_scenario, run_scenario

    summary = run_scenario(parse_scenario(CORRIDOR_WAIT), progress=False).summary
    assert summary["ended_at_limit"]["stalled"] == 1, summary["ended_at_limit"]
    assert "with 1 short of their goal that came no nearer it" in headline(summary)
