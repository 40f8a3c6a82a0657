"""Journeys: groups that enter over time, as a user writes them in a scenario file."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.journeys import entry_times
from crowdmotion.metrics import arrival, collision_audit
from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

STREAM = """
name = "stream"
method = "rvo"
seed = 2

[scene]
bounds = [[0.0, 0.0], [40.0, 12.0]]
obstacles = [{ shape = "box", lower = [18.0, 0.0], upper = [19.0, 4.0] }]

[[groups]]
name = "commuters"
count = 120
radius = 0.25
spawn = { shape = "rect", lower = [0.5, 4.0], upper = [2.0, 8.0] }
goal = { shape = "rect", lower = [37.0, 1.0], upper = [39.5, 11.0] }
enter = { rate = 2.0 }

[rvo]
max_steps = 1200
"""


def test_people_entering_at_2_per_second_for_60_s_all_enter_none_overlap_and_all_arrive():
    result = run_scenario(parse_scenario(STREAM), progress=False)
    traj, sim, summary = result.trajectories, result.extras.simulator, result.summary
    assert np.allclose(sim.enter_at, np.arange(120) * 0.5)
    assert summary["entry"]["commuters"]["entered"] == 120 and summary["entry"]["commuters"]["waiting_at_end"] == 0
    assert (sim.entry_time >= sim.enter_at - 1e-9).all()
    assert summary["entry"]["commuters"]["max_delay_s"] < 2.0, summary["entry"]
    present = traj.active_mask.sum(axis=1)
    assert present[0] == 1 and present.max() < 120, "they come in over time, not all at once"
    assert summary["agent_agent_overlaps"] == 0 and summary["agent_obstacle_penetrations"] == 0
    assert summary["arrival_rate"] == 1.0
    assert summary["mean_time_to_goal_s"] < 60, "time to goal counts from entering"


def test_an_agent_whose_entrance_is_taken_waits_off_scene_and_enters_when_there_is_room():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])), remove_on_arrival=False)
    blocker = sim.add_agents([[2, 5]], [2, 5])[0]  # stands on the entrance
    late = sim.add_agents([[2, 5]], [18, 5], enter_at=1.0)[0]
    for _ in range(12):
        sim.step()
    assert sim.waiting[late] and not sim.present[late], "3 s on, it still waits"
    sim.remove_agents([blocker])
    sim.step()
    assert not sim.waiting[late] and sim.present[late]
    assert sim.entry_time[late] == pytest.approx(3.25) and sim.entry_time[late] - sim.enter_at[late] == 2.25


def test_agents_listed_to_enter_at_the_same_time_on_the_same_spot_come_in_one_by_one():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])))
    ids = sim.add_agents([[2, 5]] * 3, [18, 5], enter_at=[0.0, 0.0, 0.0])
    assert sim.present[ids].tolist() == [True, False, False]
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while (sim.active | sim.waiting).any() and sim.time < 40:
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())
    assert sim.arrived.all() and np.all(np.diff(sim.entry_time) > 0)
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    assert collision_audit(traj).agent_agent == 0


def test_arrival_does_not_count_an_agent_that_entered_late_and_is_still_walking():
    active = np.array([[True, False, False], [True, True, False], [False, True, True]])  # 3 frames, 3 agents
    traj = cm.Trajectories(np.zeros((3, 3, 2)), 1.0, active=active)
    arrived, when = arrival(traj, lambda p: np.zeros(3, dtype=bool))
    assert arrived.tolist() == [True, False, False], "0 left after frame 1; 1 walks on; 2 never came in"
    assert when[0] == 1.0


@pytest.mark.parametrize("spec,message", [
    ({"rate": 2.0, "times": [1.0]}, "either rate"),
    ({}, "either rate"),
    ({"times": [0.0, 1.0]}, r"enter.times: 2 time\(s\) for a group of 3"),
    ({"times": [0.0, -1.0, 2.0]}, r"enter.times.1 must be a number of seconds >= 0, got -1.0"),
    ({"rate": 0.0}, "enter.rate must be a positive number"),
    ({"rate": float("nan")}, "enter.rate must be a finite number"),
    ({"rate": 1.0, "when": 3}, r"unknown key\(s\) \['when'\]"),
    ("soon", "enter must be a table"),
])
def test_entry_times_refuse_a_bad_spec_naming_the_field(spec, message):
    with pytest.raises(ValueError, match=message):
        entry_times(spec, 3)


def test_people_entering_at_2_per_second_between_10_s_and_69_5_s_all_fit_the_window():
    due = entry_times({"rate": 2.0, "start": 10.0, "end": 69.5}, 120)
    assert due[0] == 10.0 and due[-1] == 69.5 and np.allclose(np.diff(due), 0.5)
    with pytest.raises(ValueError, match=r"enter.end: 121 agents .* the window holds 120"):
        entry_times({"rate": 2.0, "start": 10.0, "end": 69.5}, 121)


def test_a_group_given_a_window_without_a_rate_is_spread_evenly_over_it():
    assert entry_times({"start": 2.0, "end": 6.0}, 5).tolist() == [2.0, 3.0, 4.0, 5.0, 6.0]
    assert entry_times({"end": 4.0}, 1).tolist() == [0.0], "one agent enters at the start"
    with pytest.raises(ValueError, match=r"enter.end must be after start \(4 s\), got 4"):
        entry_times({"start": 4.0, "end": 4.0}, 3)
    with pytest.raises(ValueError, match="enter.end must be a finite number"):
        entry_times({"end": float("nan")}, 3)


def test_entry_times_at_a_rate_from_a_start():
    assert entry_times({"rate": 4.0, "start": 10.0}, 3).tolist() == [10.0, 10.25, 10.5]
    assert entry_times({"times": [5, 0, 2]}, 3).tolist() == [5.0, 0.0, 2.0]
    assert entry_times(None, 2).tolist() == [0.0, 0.0]


@pytest.mark.parametrize("old,new,message", [
    ("enter = { rate = 2.0 }", "enter = { rate = 2.0, times = [1.0] }", "either rate"),
    ("enter = { rate = 2.0 }", "enter = { times = [1.0, 2.0] }", r"groups.0.enter.times \(group 'commuters'\): 2 time\(s\) for a group of 120"),
    ("enter = { rate = 2.0 }", "enter = { rate = 2.0, start = 5.0, end = 3.0 }",
     r"groups.0.enter.end \(group 'commuters'\): must be after start \(5 s\), got 3"),
    ("enter = { rate = 2.0 }", "enter = { rate = 2.0, end = 30.0 }",
     r"groups.0.enter.end \(group 'commuters'\): 120 agents at 2 persons/s from 0 s need until 59.5 s, after "
     r"end = 30 s: the window holds 61"),
    ("enter = { rate = 2.0 }", "enter = { times = [1.0, 2.0], end = 3.0 }", "groups.0.enter .*either rate"),
    ("enter = { rate = 2.0 }", "enter = { rate = -1.0 }", "groups.0.enter.rate"),
    ('method = "rvo"', 'method = "pso"', r"groups.0.enter.rate \(group 'commuters'\): a PSO swarm enters as one unit"),
])
def test_validate_refuses_a_bad_enter_table_naming_the_group(old, new, message):
    text = STREAM.replace(old, new)
    if new.startswith("method"):
        text = text.replace("[rvo]\nmax_steps = 1200", "")
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text)


def test_a_waiting_agent_can_be_given_another_entrance_but_one_that_entered_cannot():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10])), remove_on_arrival=False)
    sim.add_agents([[2, 5]], [2, 5])  # stands on the first entrance for good
    late = sim.add_agents([[2, 5]], [18, 5], enter_at=0.5)[0]
    sim.step()
    sim.step()
    assert sim.waiting[late]
    sim.set_entry_points([late], [2, 8])
    sim.step()
    assert not sim.waiting[late] and sim.entry_time[late] == pytest.approx(0.75)
    with pytest.raises(ValueError, match=f"set_entry_points: agent {late} has entered already"):
        sim.set_entry_points([late], [2, 2])
    with pytest.raises(ValueError, match="set_entry_points: no agent 9"):
        sim.set_entry_points([9], [2, 2])


# ---- routes: go to, wait, queue, choose, leave -------------------------------------------
GATE = """
name = "gate"
method = "rvo"
seed = 1

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]

[[groups]]
name = "riders"
count = 30
spawn = { shape = "rect", lower = [1.0, 2.0], upper = [8.0, 18.0] }

[[groups.route]]
kind = "queue"
name = "gate"
head = [30.0, 10.0]
direction = [-1.0, 0.0]
rate = 0.5

[[groups.route]]
kind = "leave"
name = "east"
area = { shape = "rect", lower = [39.0, 8.0], upper = [40.0, 12.0] }

[rvo]
max_steps = 800
"""


def _audited(result):
    summary = result.summary
    assert summary["agent_agent_overlaps"] == 0 and summary["agent_obstacle_penetrations"] == 0
    return result


def test_a_queue_of_30_is_served_in_order_at_half_a_person_per_second():
    result = _audited(run_scenario(parse_scenario(GATE), progress=False))
    queue = result.extras.journeys.queues[0]
    agents, joined, released = (np.array(x) for x in zip(*queue.served))
    assert len(agents) == 30 and sorted(agents.tolist()) == list(range(30))
    assert np.all(np.diff(joined) >= 0), "first come (to the end of the line), first served"
    gaps = np.diff(released)
    assert gaps.min() >= 2.0 - 1e-9, "never faster than 0.5 per second"
    full = gaps[len(gaps) // 3:]  # once the line has formed
    assert np.allclose(full, 2.0), full
    report = result.summary["journeys"]
    assert report["queues"]["gate"]["served"] == 30 and max(report["queues"]["gate"]["length_per_s"]) >= 15
    assert report["exits"]["east"]["left"] == 30 and result.summary["arrival_rate"] == 1.0
    # the line forms behind the head, along -x, a place every 0.65 m: 17 in line reach back 10 m
    traj, journeys = result.trajectories, result.extras.journeys
    in_line = (journeys.reached[:, 0][None] <= traj.times[:, None] + 1e-9) & (traj.stage == 0)
    frame = int(np.argmax(in_line.sum(axis=1)))
    pos = traj.positions[frame, in_line[frame]]
    off = np.abs(pos[:, 1] - 10.0)  # RVO bodies shuffling up a place sway a little
    # (two or three bodies stepping aside or still walking up may stand out: the 90th
    # percentile spreads 0.39-1.15 m over seeds 0-7, the median 0.14-0.27 m)
    assert len(pos) >= 15 and np.percentile(off, 90) < 1.25 and np.median(off) < 0.3
    # (the line's length beyond 0.65 m a place spreads -0.1-1.2 m over seeds 0-7)
    assert pos[:, 0].max() < 30.5 and 30.0 - pos[:, 0].min() == pytest.approx(0.65 * (len(pos) - 1), abs=1.5)


FOUNTAIN = """
name = "fountain"
method = "rvo"
seed = 3

[scene]
bounds = [[0.0, 0.0], [30.0, 20.0]]
obstacles = [{ shape = "circle", center = [15.0, 10.0], radius = 1.0 }]

[[groups]]
name = "strollers"
count = 12
spawn = { shape = "rect", lower = [1.0, 5.0], upper = [5.0, 15.0] }

[[groups.route]]
kind = "goto"
name = "fountain"
area = { shape = "disc", center = [15.0, 10.0], radius = 3.0 }
arrive = "free_point"

[[groups.route]]
kind = "wait"
time = 5.0

[[groups.route]]
kind = "leave"
name = "east gate"
area = { shape = "rect", lower = [29.0, 8.0], upper = [30.0, 12.0] }

[rvo]
max_steps = 600
"""


def test_agents_wait_5_s_at_the_fountain_then_leave():
    result = _audited(run_scenario(parse_scenario(FOUNTAIN), progress=False))
    traj, journeys = result.trajectories, result.extras.journeys
    assert np.allclose(journeys.until[:, 1] - journeys.since[:, 1], 5.0)
    for a in range(traj.n_agents):  # goto, then wait, then leave, in that order
        seen = traj.stage[:, a][traj.stage[:, a] >= 0]
        assert seen[0] == 0 and np.all(np.diff(seen) >= 0) and seen[-1] == 2
        waiting = np.flatnonzero(traj.stage[:, a] == 1)
        assert len(waiting) >= 19
        # they stay by the fountain while they wait (stepping aside for those passing, as RVO walkers do)
        assert np.linalg.norm(traj.positions[waiting, a] - [15.0, 10.0], axis=1).max() <= 3.0 + 1.5
    rows = {r["name"]: r for r in result.summary["journeys"]["stages"]["strollers"]}
    assert rows["wait 5 s"]["reached"] == 12 and rows["wait 5 s"]["mean_time_s"] == 5.0
    assert result.summary["journeys"]["exits"]["east gate"]["left"] == 12
    assert traj.metadata["stages"]["strollers"][1] == {"id": 1, "path": "route[1]", "kind": "wait", "name": "wait 5 s"}


TWO_EXITS = """
name = "two exits"
method = "rvo"
seed = 4

[scene]
bounds = [[0.0, 0.0], [40.0, 12.0]]

[[groups]]
name = "evacuees"
count = 40
spawn = { shape = "rect", lower = [12.0, 1.0], upper = [28.0, 11.0] }

[[groups.route]]
kind = "choose"
by = "nearest"
among = [
  { kind = "leave", name = "west", area = { shape = "rect", lower = [0.0, 5.0], upper = [0.5, 7.0] } },
  { kind = "leave", name = "east", area = { shape = "rect", lower = [39.5, 5.0], upper = [40.0, 7.0] } },
]

[rvo]
max_steps = 800
"""


def _exit_taken(traj) -> np.ndarray:
    """The last stage id each agent was seen in."""
    last = np.array([traj.stage[:, a][traj.stage[:, a] >= 0][-1] for a in range(traj.n_agents)])
    return last


def test_choose_nearest_exit_each_agent_leaves_by_the_nearer_exit():
    result = _audited(run_scenario(parse_scenario(TWO_EXITS), progress=False))
    traj = result.trajectories
    taken = _exit_taken(traj)  # stage ids: 0 choose, 1 west, 2 east
    nearer_east = traj.positions[0, :, 0] > 20.0
    assert np.array_equal(taken == 2, nearer_east)
    exits = result.summary["journeys"]["exits"]
    assert exits["west"]["left"] + exits["east"]["left"] == 40 and result.summary["arrival_rate"] == 1.0
    assert exits["east"]["flow_per_s"] > 0 and exits["east"]["evacuation_time_s"] <= traj.times[-1]


def test_least_crowded_sends_some_to_the_farther_exit_when_one_is_swamped():
    text = TWO_EXITS.replace('lower = [12.0, 1.0], upper = [28.0, 11.0]', 'lower = [1.0, 1.0], upper = [9.0, 11.0]')
    text = text.replace('name = "west", area', 'name = "west", capacity = 0.5, area')
    nearest = run_scenario(parse_scenario(text), progress=False)
    assert (_exit_taken(nearest.trajectories) == 2).sum() == 0, "all are nearer the west exit"
    crowded = _audited(run_scenario(parse_scenario(text.replace('by = "nearest"', 'by = "least_crowded"')),
                                    progress=False))
    east = int((_exit_taken(crowded.trajectories) == 2).sum())
    assert 0 < east < 40, east
    assert crowded.summary["journeys"]["exits"]["east"]["left"] == east


def test_validate_refuses_a_queue_stage_for_a_pso_group():
    text = GATE.replace('method = "rvo"', 'method = "pso"').replace("[rvo]\nmax_steps = 800", "")
    with pytest.raises(ScenarioError, match=r"groups.0.route.0 \(group 'riders'\): a 'queue' stage, but method "
                                            r"'pso' follows only goto, choose, leave stages; method 'rvo' follows queue stages"):
        parse_scenario(text)


@pytest.mark.parametrize("old,new,message", [
    ("rate = 0.5", "rate = 0.0", r"groups.0.route.0.rate \(group 'riders'\): must be more than 0"),
    ("rate = 0.5", "rate = 0.5\nspacing = 0.3", r"route.0 \(queue 'gate'\): spacing 0.3 m is less than a body"),
    ("direction = [-1.0, 0.0]", "direction = [1.0, 0.0]", r"route.0 \(queue 'gate'\): place 16 in line at \[40.4, 10\] "
                                                          "lies outside scene.bounds"),
    ('kind = "leave"\nname = "east"', 'kind = "wait"\ntime = { uniform = [5.0, 2.0] }\n[[groups.route]]\nkind = "leave"\nname = "east"',
     r"groups.0.route.1.time.uniform \(group 'riders'\): low 5 exceeds high 2"),
    # the route's first place is the group's goal: named as the queue's head, not as 'goal'
    ("[scene]\nbounds = [[0.0, 0.0], [40.0, 20.0]]",
     '[scene]\nbounds = [[0.0, 0.0], [40.0, 20.0]]\nobstacles = [{ shape = "box", lower = [29.0, 9.0], upper = [31.0, 11.0] }]',
     r"route.0 \(queue 'gate'\): its head \[30, 10\] lies inside scene.obstacles.0 .*: put the head where"),
])
def test_validate_names_the_stage_of_a_bad_route(old, new, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(GATE.replace(old, new))


def test_a_group_without_a_route_runs_as_before():
    rng = np.random.default_rng(5)
    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    groups = [cm.Group("walkers", 5, cm.groups.Rect([1, 1], [4, 9]), cm.groups.Rect([17, 1], [19, 9]))]
    sim = rvo.simulation.build_simulator(scene, groups, rvo.RVOParams(), rng)
    state = rng.bit_generator.state
    assert rvo.simulation.build_journeys(sim, scene, groups, rng) is None
    assert rng.bit_generator.state == state, "no draw taken: the run's random numbers are the same"
    result = run_scenario(parse_scenario(STREAM), progress=False)
    assert result.trajectories.stage is None and "journeys" not in result.summary
    assert "stages" not in result.trajectories.metadata


def _stand_variants() -> dict:
    """The built-in rvo_stand_exits three ways: each spectator to a random point of the
    concourse (no route), to the nearest exit (chosen once), to the least crowded one
    (weighed again on the way, as the built-in does)."""
    from crowdmotion.builtin import builtin_scenarios

    text = next(p for p in builtin_scenarios() if p.stem == "rvo_stand_exits").read_text()
    a, b = text.index("[[groups.route]]"), text.index("[rvo]")
    concourse = 'goal = { shape = "rect", lower = [0.5, 0.5], upper = [29.5, 5.0] }\nattributes ='
    once = "\n".join(line for line in text.splitlines() if not line.startswith("rechoose")) + "\n"
    return {"random point": text[:a].replace("attributes =", concourse) + text[b:] + 'goal_assignment = "sample"\n',
            "nearest": once.replace('by = "least_crowded"', 'by = "nearest"'), "least crowded": text}


def test_stand_evacuation_nearest_beats_a_random_point_and_least_crowded_is_at_least_as_fast_as_nearest():
    # the stand's third exit lies farther off than the other two (issue 30, Must hold)
    out = {}
    for name, text in _stand_variants().items():
        result = _audited(run_scenario(parse_scenario(text), progress=False))
        assert result.summary["arrival_rate"] == 1.0, name
        traj = result.trajectories
        out[name] = traj.times[np.flatnonzero(traj.active_mask.any(axis=1))[-1]]
    assert out["nearest"] < out["random point"], out
    assert out["least crowded"] <= out["nearest"], out


def test_a_run_with_routes_draws_its_queues_and_exits_over_time(tmp_path):
    from crowdmotion.outputs import write_run

    result = run_scenario(parse_scenario(GATE), progress=False)
    written = {p.name for p in write_run(result, tmp_path, plots=["paths"], pictures=None)}
    assert {"paths.png", "journeys.png"} <= written
    assert (tmp_path / "journeys.png").stat().st_size > 10_000
    no_route = GATE.split("[[groups.route]]")[0] + 'goal = { shape = "rect", lower = [39.0, 8.0], upper = [40.0, 12.0] }\n'
    plain = run_scenario(parse_scenario(no_route), progress=False)
    assert "journeys.png" not in {p.name for p in write_run(plain, tmp_path / "plain", plots=["paths"], pictures=None)}


TWO_GATES = """
name = "two gates"
method = "rvo"
seed = 4

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]

[[groups]]
name = "late"
count = 5
radius = 0.25
spawn = { shape = "rect", lower = [2.0, 2.0], upper = [5.0, 6.0] }
route = [
  { kind = "choose", by = "least_crowded", RECHOOSE among = [
    { kind = "queue", name = "south gate", head = [30.0, 4.0], direction = [-1.0, 0.0], rate = 0.5 },
    { kind = "queue", name = "north gate", head = [30.0, 16.0], direction = [-1.0, 0.0], rate = 0.5 },
  ] },
  { kind = "leave", name = "east", area = { shape = "rect", lower = [37.0, 0.5], upper = [39.5, 19.5] } },
]

[[groups]]
name = "crowd"
count = 14
radius = 0.25
spawn = { shape = "rect", lower = [20.0, 5.0], upper = [26.0, 9.0] }
enter = { times = [3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0] }
route = [
  { kind = "queue", name = "south gate", head = [30.0, 4.0], direction = [-1.0, 0.0], rate = 0.5 },
  { kind = "leave", name = "east", area = { shape = "rect", lower = [37.0, 0.5], upper = [39.5, 19.5] } },
]

[rvo]
max_steps = 600
"""


def _gates(rechoose: str):
    result = run_scenario(parse_scenario(TWO_GATES.replace("RECHOOSE", rechoose)), progress=False)
    queues = {q.stage.name: [int(a) for a, *_ in q.served] for q in result.extras.journeys.queues}
    return result, queues


def test_with_rechoose_late_agents_bound_for_a_gate_whose_queue_grows_switch_to_the_other_gate():
    # the 5 "late" agents choose the nearer south gate while it is empty; at t = 3 s a crowd
    # of 14 heads for it too. Chosen once, they queue behind the crowd; re-choosing every 2 s
    # on their way, they switch to the empty north gate, once each, and are through sooner
    once, once_queues = _gates("")
    again, again_queues = _gates("rechoose = 2.0,")
    late = list(range(5))
    assert set(late) <= set(once_queues["south gate"]) and once_queues["north gate"] == []
    assert sorted(again_queues["north gate"]) == late and not set(late) & set(again_queues["south gate"])
    for result in (once, again):
        assert result.summary["journeys"]["finished"] == 19
        assert result.summary["agent_agent_overlaps"] == 0 and result.summary["agent_obstacle_penetrations"] == 0
    stages = again.trajectories.stage[:, late]
    ids = {row["name"]: row["id"] for row in again.summary["journeys"]["stages"]["late"]}
    for k in late:  # south, then north: one switch, no flip-flop
        seen = [int(s) for s in dict.fromkeys(stages[:, k].tolist()) if s >= 0]
        assert seen == [ids["south gate"], ids["north gate"], ids["east"]], seen
    done = lambda r: r.extras.journeys.finished_at[late].max()  # noqa: E731
    assert done(again) < done(once) - 10.0


def _taken_exit(rechoose, to=(20.0, 17.0), north=((30, 18.5), (34, 19.5))):
    """The exit a walker re-choosing the nearest of two every ``rechoose`` seconds (None:
    chosen once) leaves by, when 2 s after setting off for the south exit it is put at
    ``to``: across the room, by the north one (a player the game teleported, one the
    crowd carried over)."""
    from crowdmotion.groups import Group, Points, Rect
    from crowdmotion.rvo.params import RVOParams
    from crowdmotion.rvo.simulation import build_journeys, build_simulator
    from crowdmotion.stages import Choose, Leave

    scene = cm.Scene(bounds=([0, 0], [40, 20]))
    south, north = Rect([30, 0.5], [34, 1.5]), Rect(*north)
    route = [Choose([Leave(south, name="south"), Leave(north, name="north")], "nearest", rechoose=rechoose)]
    group = Group("walker", 1, spawn=Points([[2.0, 9.0]]), goal=south, attributes={"route": route})
    rng = np.random.default_rng(0)
    params = RVOParams()
    sim = build_simulator(scene, [group], params, rng)
    journeys = build_journeys(sim, scene, [group], rng)
    journeys.update(sim, params.time_step)
    for _ in range(8):
        sim.step()
    sim.place([0], [to])
    while sim.steps < 400 and journeys.busy(sim.active):
        sim.step()
    return [name for name, times in journeys.exits.items() if times]


def test_rechoosing_the_nearest_a_walker_put_across_the_room_takes_the_exit_now_nearer():
    assert _taken_exit(None) == ["south"], "chosen once, it walks back to the exit it took"
    assert _taken_exit(1.0) == ["north"]


def test_a_walker_bound_for_one_exit_that_finds_itself_in_another_of_its_choice_leaves_there():
    # RiMEA 11 by nearest: people bound for the near exit pressed through the far door
    # into its closed exit area stayed there (one for 420 s) instead of leaving
    assert _taken_exit(None, to=(32.0, 19.0)) == ["north"]
    # standing where its own exit's area and the other's overlap, it leaves by its own
    assert _taken_exit(None, to=(32.0, 1.0), north=((31, 0.5), (34, 5.0))) == ["south"]


@pytest.mark.parametrize("written,message", [
    ('by = "weights", weights = [1.0, 1.0], rechoose = 2.0,',
     r'groups\.0\.route\.0 \(group \'late\'\): rechoose and rechoose_margin go with by = "nearest" or '
     r'"least_crowded", not by = "weights"'),
    ('by = "least_crowded", rechoose = -1.0,', r"groups\.0\.route\.0\.rechoose \(group 'late'\): must be more "
                                               r"than 0 \(got -1\.0\)"),
    ('by = "least_crowded", rechoose = nan,', r"groups\.0\.route\.0\.rechoose \(group 'late'\): must be a finite "
                                              r"number \(got nan\)"),
    ('by = "least_crowded", rechoose_margin = 1.0,', r"groups\.0\.route\.0 \(group 'late'\): rechoose_margin goes "
                                                     r"with rechoose"),
])
def test_validate_refuses_a_bad_rechoose_naming_it(written, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(TWO_GATES.replace('by = "least_crowded", RECHOOSE', written))


def test_a_choose_stage_in_python_refuses_a_bad_rechoose_naming_it():
    from crowdmotion.stages import Choose, Leave
    among = [Leave(cm.Rect([0, 0], [1, 1])), Leave(cm.Rect([5, 0], [6, 1]))]
    with pytest.raises(ValueError, match="choose.rechoose goes with by = 'nearest' or 'least_crowded'"):
        Choose(among, "weights", [1.0, 1.0], rechoose=2.0)
    assert Choose(among, "nearest", rechoose=2.0).rechoose == 2.0
    with pytest.raises(ValueError, match="choose.rechoose_margin goes with rechoose"):
        Choose(among, "nearest", rechoose_margin=5.0)  # a margin that would be ignored
    with pytest.raises(ValueError, match="choose.rechoose_margin goes with rechoose"):
        Choose(among, "weights", [1.0, 1.0], rechoose_margin=1.0)
    with pytest.raises(ValueError, match=r"choose.rechoose must be a number of seconds > 0, got nan"):
        Choose(among, "least_crowded", rechoose=float("nan"))
    with pytest.raises(ValueError, match=r"choose.rechoose_margin must be a number of seconds >= 0, got -1"):
        Choose(among, "least_crowded", rechoose=2.0, rechoose_margin=-1)
    assert Choose(among, "least_crowded").rechoose is None, "chosen once by default"


TWO_DOORS = STREAM.replace('spawn = { shape = "rect", lower = [0.5, 4.0], upper = [2.0, 8.0] }\n', "").replace(
    "count = 120", "count = 40").replace("enter = { rate = 2.0 }", """enter = { rate = 4.0, end = 10.0, weights = [3, 1], entrances = [
    { shape = "rect", lower = [0.5, 1.0], upper = [2.0, 5.0] },
    { shape = "disc", center = [10.0, 10.5], radius = 1.0 } ] }""")


def test_a_group_with_two_entrances_uses_both_in_the_given_proportions_and_none_overlap():
    result = run_scenario(parse_scenario(TWO_DOORS), progress=False)
    traj, sim, summary = result.trajectories, result.extras.simulator, result.summary
    assert np.bincount(sim.entrance).tolist() == [30, 10], "weights 3 : 1 of 40"
    first = traj.positions[np.argmax(traj.active_mask, axis=0), np.arange(40)]  # where each came in
    west, north = sim.entrance == 0, sim.entrance == 1
    assert cm.Rect([0.5, 1.0], [2.0, 5.0]).contains(first[west]).all()
    assert cm.Disc([10.0, 10.5], 1.0).contains(first[north]).all()
    doors = summary["entry"]["commuters"]["entrances"]
    assert [d["entered"] for d in doors] == [30, 10] and summary["entry"]["commuters"]["waiting_at_end"] == 0
    assert summary["agent_agent_overlaps"] == 0 and summary["agent_obstacle_penetrations"] == 0
    assert summary["arrival_rate"] == 1.0


@pytest.mark.parametrize("old,new,message", [
    ('{ shape = "disc", center = [10.0, 10.5], radius = 1.0 } ]', '{ shape = "disc", center = [10.0, 11.5], radius = 1.0 } ]',
     r"enter.entrances.1: disc .* reaches outside scene.bounds"),
    ("weights = [3, 1]", "weights = [3, 1, 1]", r"groups.0.enter.weights \(group 'commuters'\): 3 weight\(s\) for 2 entrance\(s\)"),
    ("weights = [3, 1]", "weights = [0, 0]", r"groups.0.enter.weights \(group 'commuters'\): must be finite numbers >= 0, not all 0"),
    ("count = 40", 'count = 40\nspawn = { shape = "point", position = [1.0, 6.0] }', "give a spawn or enter.entrances, not both"),
])
def test_validate_refuses_bad_entrances_naming_the_field(old, new, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(TWO_DOORS.replace(old, new))


# ---- what researchers measure, against hand-computed values ------------------------------
class Teleport:
    """Walkers (:class:`crowdmotion.journeys.Walkers`) that stand on any goal they are
    given at once and count as arrived there after the next step: times are then
    whole steps, worked out by hand."""

    def __init__(self, n: int, dt: float):
        self.positions, self.active, self.time, self.dt = np.zeros((n, 2)), np.ones(n, bool), 0.0, dt
        self._sent, self._arrived, self._leave = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, bool)

    @property
    def arrived(self):
        return self._arrived

    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere=False, leave=None):
        ids = np.atleast_1d(agents)
        self.positions[ids] = np.broadcast_to(np.asarray(goals, float).reshape(-1, 2), (len(ids), 2))
        self._sent[ids], self._arrived[ids] = True, False
        if leave is not None:
            self._leave[ids] = leave

    def walking_distance(self, points, region):
        return np.linalg.norm(region.nearest(points) - points, axis=1)

    def add_goal_regions(self, regions):
        pass

    def step(self, journeys):
        self.time += self.dt
        self._arrived |= self._sent
        self._sent[:] = False
        journeys.update(self, self.dt)
        self.active &= ~(self._arrived & self._leave)  # an exit takes out who reached it


def test_one_leaving_a_line_moves_that_line_up_and_sends_no_one_else_new_goals():
    # agents 0-2 queue at counter A; agent 3, bound for counter B, is still on its way
    # (it never arrives): taking agent 0 out moves A's line up and leaves 3 alone
    from crowdmotion.journeys import Journeys
    from crowdmotion.stages import Queue

    class Slow(Teleport):
        @property
        def arrived(self):
            return self._arrived & (np.arange(4) != 3)

    routes = [[Queue([10.0, 0.0], rate=0.01, direction=[-1.0, 0.0], name="A")],
              [Queue([10.0, 20.0], rate=0.01, direction=[-1.0, 0.0], name="B")]]
    w = Slow(4, 0.5)
    journeys = Journeys(routes, [0, 0, 0, 1], [None, None], np.full(4, 0.25), np.full(4, 1.3), key=1)
    journeys.update(w, w.dt)
    w.step(journeys)
    line = list(journeys.queues[0].members)
    assert sorted(line) == [0, 1, 2] and list(journeys.queues[1].approaching) == [3]
    sent = []
    w.set_goals = lambda agents, goals, **kw: sent.append(np.atleast_1d(agents).tolist())
    w.active[line[0]] = False
    w.step(journeys)
    assert sent and sorted(sum(sent, [])) == sorted(line[1:]), sent  # A's line moves up, nobody else


def test_a_queue_s_waits_over_time_and_an_exit_s_flow_are_reported_as_worked_out_by_hand():
    # 3 people queue at a counter serving 1 person/s, then leave; steps of 0.5 s. By hand:
    # all three reach the end of the line at 0.5 s and join it (0, 1, 2 by id); service
    # starts at once, so they are served at 1.5, 2.5 and 3.5 s (waits 1, 2 and 3 s),
    # reach the exit a step later and leave at 2.0, 3.0 and 4.0 s
    from crowdmotion.groups import Rect
    from crowdmotion.journeys import Journeys
    from crowdmotion.stages import Leave, Queue

    route = [Queue([10.0, 0.0], rate=1.0, direction=[-1.0, 0.0], name="counter"),
             Leave(Rect([20.0, -1.0], [21.0, 1.0]), name="door")]
    w = Teleport(3, 0.5)
    journeys = Journeys([route], [0, 0, 0], [None], np.full(3, 0.25), np.full(3, 1.3), key=1)
    journeys.update(w, w.dt)
    while journeys.busy(w.active):
        w.step(journeys)
    report = journeys.report(["visitors"])
    counter, door = report["queues"]["counter"], report["exits"]["door"]
    assert counter["served_s"] == [1.5, 2.5, 3.5] and counter["wait_s"] == [1.0, 2.0, 3.0]
    assert counter["mean_wait_s"] == 2.0 and counter["max_wait_s"] == 3.0
    assert counter["length_per_s"][:5] == [0, 3, 2, 1, 0]
    assert door == {"left": 3, "first_s": 2.0, "evacuation_time_s": 4.0, "flow_per_s": 1.0, "left_per_s": [0, 0, 1, 1, 1],
                    "steady_flow_per_s": None, "steady_span_s": None}  # too few who left for a stationary part
    queue_row, leave_row = report["stages"]["visitors"]
    assert queue_row["mean_time_s"] == 2.5 and queue_row["max_time_s"] == 3.5  # from 0 s to being served
    assert leave_row["mean_time_s"] == 0.5
    assert report["groups"]["visitors"] == {
        "queues": {"counter": {"served": 3, "mean_wait_s": 2.0, "max_wait_s": 3.0}},
        "exits": {"door": {"left": 3, "first_s": 2.0, "evacuation_time_s": 4.0}}}


def test_an_exits_steady_flow_leaves_out_a_straggler_that_thins_its_flow_over_first_to_last():
    # 20 people served at a counter at 1 person/s leave by the door at 2, 3, ... 21 s; one
    # more stands 30 s where it came in and leaves by the same door at 30.5 s
    import json

    from crowdmotion.groups import Rect
    from crowdmotion.journeys import Journeys
    from crowdmotion.stages import Leave, Queue, Wait

    door = Leave(Rect([20.0, -1.0], [21.0, 1.0]), name="door")
    routes = [[Queue([10.0, 0.0], rate=1.0, direction=[-1.0, 0.0], name="counter"), door], [Wait(30.0), door]]
    w = Teleport(21, 0.5)
    journeys = Journeys(routes, [0] * 20 + [1], [None, None], np.full(21, 0.25), np.full(21, 1.3), key=1)
    journeys.update(w, w.dt)
    while journeys.busy(w.active):
        w.step(journeys)
    row = journeys.report(["crowd", "straggler"])["exits"]["door"]
    assert row["first_s"] == 2.0 and row["evacuation_time_s"] == 30.5
    assert row["flow_per_s"] == pytest.approx(20 / 28.5)  # (n - 1) / (last - first), thinned by the straggler
    # the 10-90 % of those who left (the 3rd, 4 s, to the 19th, 20 s): the counter's rate
    assert row["steady_flow_per_s"] == 1.0 and row["steady_span_s"] == [4.0, 20.0]
    json.dumps(row)  # plain numbers for summary.json


def test_the_report_of_a_run_with_routes_gives_each_group_its_stages_queues_and_exits(tmp_path, capsys):
    import json

    from crowdmotion.cli import main

    path = tmp_path / "gate.toml"
    path.write_text(GATE)
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "-q"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["journeys"]
    capsys.readouterr()
    assert main(["report", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert "queue gate: 30 served" in printed and "exit east: 30 left" in printed
    riders = json.loads((tmp_path / "out" / "report.json").read_text())["riders"]["journeys"]
    assert riders["stages"] == summary["stages"]["riders"]
    gate = summary["queues"]["gate"]
    assert riders["queues"]["gate"] == {"served": 30, "mean_wait_s": gate["mean_wait_s"], "max_wait_s": gate["max_wait_s"]}
    assert riders["exits"]["east"]["left"] == 30
    assert riders["exits"]["east"]["evacuation_time_s"] == summary["exits"]["east"]["evacuation_time_s"]
    assert len(gate["served_s"]) == len(gate["wait_s"]) == 30 and max(gate["wait_s"]) == gate["max_wait_s"]


# ---- choosing between whole routes (a choose's options as branches) -------------------
SPLIT = """
name = "fountain or straight out"
method = "METHOD"
seed = 1

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]
obstacles = [{ shape = "circle", center = [20.0, 10.0], radius = 1.0 }]

[[groups]]
name = "walkers"
count = COUNT
spawn = { shape = "rect", lower = [1.0, 2.0], upper = [8.0, 18.0] }
enter = { rate = 2.0 }
route = [
  { kind = "choose", name = "plan", by = "weights", weights = [3, 7], among = [
    [ { kind = "goto", name = "fountain", area = { shape = "disc", center = [20.0, 10.0], radius = 4.0 }, arrive = "free_point" },
      { kind = "wait", name = "at the fountain", time = 5.0 },
      { kind = "leave", name = "east", area = { shape = "rect", lower = [39.0, 8.0], upper = [40.0, 12.0] } } ],
    { kind = "leave", name = "west", area = { shape = "rect", lower = [0.0, 8.0], upper = [0.5, 12.0] } },
  ] },
]
"""


def _split(count: int = 100, method: str = "rvo", steps: str = "[rvo]\nmax_steps = 1500\n"):
    return parse_scenario(SPLIT.replace("METHOD", method).replace("COUNT", str(count)) + steps)


def test_a_group_of_100_splits_30_70_between_the_fountain_route_and_the_west_exit():
    result = _audited(run_scenario(_split(), progress=False))
    traj, report = result.trajectories, result.summary["journeys"]
    # stage ids, depth first: 0 the choose, 1-3 the fountain branch (goto, wait, leave east), 4 leave west
    assert [s["path"] for s in traj.metadata["stages"]["walkers"]] == [
        "route[0]", "route[0].among[0][0]", "route[0].among[0][1]", "route[0].among[0][2]", "route[0].among[1]"]
    seen = [traj.stage[:, a][traj.stage[:, a] >= 0] for a in range(100)]
    fountain = np.array([1 in s for s in seen])
    assert 29 <= fountain.sum() <= 31, fountain.sum()
    for s, took in zip(seen, fountain):  # the branch's stages in order, then out; or straight out west
        assert s[np.r_[True, np.diff(s) != 0]].tolist() == ([1, 2, 3] if took else [4])
    waited = np.flatnonzero(fountain)
    journeys = result.extras.journeys
    assert np.allclose(journeys.until[waited, 2] - journeys.since[waited, 2], 5.0), "each waits 5 s at the fountain"
    at_fountain = traj.positions[traj.stage == 2]
    assert np.linalg.norm(at_fountain - [20.0, 10.0], axis=1).max() <= 4.0 + 1.5
    assert report["exits"]["east"]["left"] == fountain.sum() and report["exits"]["west"]["left"] == 100 - fountain.sum()
    assert report["stages"]["walkers"][0]["chosen"] == [int(fountain.sum()), 100 - int(fountain.sum())]
    assert result.summary["arrival_rate"] == 1.0 and report["finished"] == 100


def test_a_branch_that_does_not_leave_goes_on_with_the_stage_after_the_choose():
    # in Python: a third visit the fountain, the rest go straight on; then everyone leaves east
    from crowdmotion.groups import Disc, Rect
    from crowdmotion.stages import Choose, GoTo, Leave, Wait

    east = Leave(Rect([39.0, 8.0], [40.0, 12.0]), name="east")
    route = [Choose([[GoTo(Disc([20.0, 10.0], 4.0), arrive="free_point"), Wait(3.0)], []], by="weights",
                    weights=[1, 2]), east]
    scene = cm.Scene(bounds=([0, 0], [40, 20]), obstacles=[cm.Circle([20, 10], 1.0)])
    group = cm.Group("walkers", 30, cm.groups.Rect([1, 2], [8, 18]), east.area, attributes={"route": route})
    result = rvo.simulation.run(scene, [group], rvo.RVOParams(max_steps=1200), np.random.default_rng(2))
    traj = result.trajectories
    audit = collision_audit(traj, scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0
    # stage ids: 0 the choose (passed at once), 1 goto and 2 wait of the fountain branch, 3 leave east
    seen = [set(traj.stage[:, a][traj.stage[:, a] >= 0].tolist()) for a in range(30)]
    assert sum(s == {1, 2, 3} for s in seen) == 10 and sum(s == {3} for s in seen) == 20
    assert result.journeys.report(["walkers"])["exits"]["east"]["left"] == 30


def test_set_route_sends_live_agents_along_the_branch_whose_first_place_is_nearer():
    # two branches: the west kiosk then the east exit, or the east kiosk then the west exit;
    # by = "nearest" weighs each by its kiosk, whatever comes after
    from crowdmotion.groups import Disc, Rect
    from crowdmotion.stages import Choose, GoTo, Leave

    west, east = Leave(Rect([0.0, 8.0], [0.5, 12.0]), name="west"), Leave(Rect([39.5, 8.0], [40.0, 12.0]), name="east")
    route = [Choose([[GoTo(Disc([8.0, 10.0], 1.5), name="west kiosk"), east],
                     [GoTo(Disc([32.0, 10.0], 1.5), name="east kiosk"), west]], by="nearest")]
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 20])), remove_on_arrival=False)
    starts = np.random.default_rng(3).uniform([12, 2], [28, 18], size=(20, 2))
    starts = starts[np.r_[True, np.linalg.norm(np.diff(starts, axis=0), axis=1) > 0.6]]
    ids = sim.add_agents(starts, starts)
    sim.set_route(ids, route)
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.journeys.busy(sim.active) and sim.time < 120:
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    audit = collision_audit(traj, sim.scene)
    assert audit.agent_agent == 0 and audit.agent_obstacle == 0
    to_east_kiosk = np.isfinite(sim.journeys.reached[ids, 3])  # 0 choose, 1 west kiosk, 2 east, 3 east kiosk, 4 west
    assert np.array_equal(to_east_kiosk, starts[:, 0] > 20.0)
    exits = sim.journeys.report([])["exits"]
    assert exits["west"]["left"] == to_east_kiosk.sum() and exits["east"]["left"] == len(ids) - to_east_kiosk.sum()


@pytest.mark.parametrize("old,new,message", [
    ('time = 5.0 },', 'time = -5.0 },', r"groups.0.route.0.among.0.1.time \(group 'walkers'\): must be at least 0"),
    ('by = "weights", weights = [3, 7]', 'by = "nearest"',
     None),  # a branch beginning with a goto is weighed by it: accepted
    ('{ kind = "goto", name = "fountain"', '{ kind = "wait", time = 1.0 }, { kind = "goto", name = "fountain"',
     None),  # with weights a branch may begin with anything
    ('by = "weights", weights = [3, 7], among = [\n    [ { kind = "goto"',
     'by = "nearest", among = [\n    [ { kind = "wait", time = 1.0 }, { kind = "goto"',
     r"groups.0.route.0.among.0 \(group 'walkers'\): by = 'nearest' weighs each option by the place it leads to "
     r"first, but this branch begins with a wait"),
    ('{ kind = "wait", name = "at the fountain", time = 5.0 },',
     '{ kind = "leave", name = "early", area = { shape = "rect", lower = [39.0, 0.0], upper = [40.0, 2.0] } },',
     r"groups.0.route.0.among.0.1 \(group 'walkers'\): agents leave the scene at a leave stage, so it must be the "
     r"branch's last"),
    ('upper = [40.0, 12.0] } } ],', 'upper = [41.0, 12.0] } } ],',
     r"route.0.among.0.2 \(leave 'east'\) area: rect \[39, 8\]-\[41, 12\] reaches outside scene.bounds"),
    (']\n"""', ']\n', None),
    # a wait written as an option by itself: validate says to put it in a branch
    ('{ kind = "leave", name = "west", area = { shape = "rect", lower = [0.0, 8.0], upper = [0.5, 12.0] } },',
     '{ kind = "wait", time = 2.0 },',
     r"groups.0.route.0.among.1 \(group 'walkers'\): a wait stage is no option by itself .*; put it in a branch "
     r"after the place it happens at"),
])
def test_validate_names_the_stage_of_a_bad_branch(old, new, message):
    text = SPLIT.replace("METHOD", "rvo").replace("COUNT", "20").replace(old, new)
    if message is None:
        parse_scenario(text)
    else:
        with pytest.raises(ScenarioError, match=message):
            parse_scenario(text)


def test_a_choose_followed_by_more_stages_must_not_have_a_branch_that_leaves():
    text = SPLIT.replace("METHOD", "rvo").replace("COUNT", "20").replace(
        "  ] },\n]", '  ] },\n  { kind = "wait", time = 1.0 },\n]')
    with pytest.raises(ScenarioError, match=r"groups.0.route.0 \(group 'walkers'\): agents taking among.0 leave the "
                                            r"scene, so the choose must be the last stage"):
        parse_scenario(text)


def test_validate_refuses_a_wait_in_a_branch_for_a_pso_swarm_naming_it():
    text = SPLIT.replace("METHOD", "pso").replace("COUNT", "20")
    with pytest.raises(ScenarioError, match=r"groups.0.route.0.among.0.1 \(group 'walkers'\): a 'wait' stage, but "
                                            r"method 'pso' follows only goto, choose, leave stages"):
        parse_scenario(text)


def test_validate_warns_when_people_are_due_after_the_run_ends():
    # 120 at 2 per second need until 59.5 s; 100 steps of 0.25 s end the run at 25 s
    with pytest.warns(UserWarning, match=r"group 'commuters' \(groups\.0\) enter: 69 of 120 agents are due after "
                                         r"the run ends at 25 s \(\[rvo\] max_steps x time_step\), the last at 59\.5 s"):
        parse_scenario(STREAM.replace("max_steps = 1200", "max_steps = 100"))


DOOR_EXIT = """
name = "door exit"
method = "rvo"
seed = 0

[scene]
bounds = [[0.0, 0.0], [9.0, 6.0]]
obstacles = [
  { shape = "box", lower = [6.0, 0.0], upper = [6.3, 2.5] },
  { shape = "box", lower = [6.0, 3.5], upper = [6.3, 6.0] },
]

[[groups]]
name = "room"
count = 30
spawn = { shape = "rect", lower = [0.5, 0.5], upper = [5.5, 5.5] }

[[groups.route]]
kind = "leave"
name = "door"
area = { shape = "rect", lower = [6.3, 2.5], upper = [7.0, 3.5] }
"""


def _last_seen(traj) -> np.ndarray:
    """(N, 2) where each agent was last active."""
    last = traj.n_frames - 1 - np.argmax(traj.active_mask[::-1], axis=0)
    return traj.positions[last, np.arange(traj.n_agents)]


def test_walkers_leaving_by_an_exit_area_behind_a_door_pass_the_door_first():
    # heading for the area's edge, each left up to arrival_radius short of it: in front of
    # the door, so that nobody ever walked through it (a door-line count saw no one)
    result = _audited(run_scenario(parse_scenario(DOOR_EXIT), progress=False))
    end = _last_seen(result.trajectories)
    assert result.summary["arrival_rate"] == 1.0
    assert np.all(end[:, 0] >= 6.3) and np.all((end[:, 1] >= 2.5) & (end[:, 1] <= 3.5)), end


def test_walkers_leaving_by_a_strip_too_thin_for_their_centre_still_leave():
    # an exit strip along the scene's edge narrower than a body: its inside cannot be
    # reached, and each leaves where its body fits against the edge
    sim = rvo.Simulator(cm.Scene([[0.0, 0.0], [9.0, 6.0]]))
    strip = cm.Rect([8.9, 2.0], [9.0, 4.0])
    sim.add_agents(np.array([[1.0, 3.0], [1.0, 2.0]]), strip.center, goal_region=strip, arrive_anywhere=True)
    for _ in range(200):
        sim.step()
        if not sim.active.any():
            break
    assert not sim.active.any() and np.all(sim.positions[:, 0] >= 8.5), sim.positions


def test_a_run_cut_short_whose_routes_all_leave_does_not_blame_routes_that_do_not_leave():
    # a user's plaza: everyone's route ends with a leave stage; at the step limit the
    # headline told them 9 "finished a route that does not leave" (those who had left)
    from crowdmotion.metrics import headline

    text = STREAM.replace('goal = { shape = "rect", lower = [37.0, 1.0], upper = [39.5, 11.0] }\n',
                          'route = [{ kind = "leave", name = "east", area = { shape = "rect", lower = [37.0, 1.0], '
                          'upper = [39.5, 11.0] } }]\n').replace("max_steps = 1200", "max_steps = 150")
    result = run_scenario(parse_scenario(text), progress=False)
    journeys = result.summary["journeys"]
    assert result.summary["ended_at_limit"] and journeys["finished"] > 0
    assert journeys["standing_at_end"] == 0
    assert "does not leave" not in headline(result.summary)


def test_a_first_in_line_overtaken_in_a_single_file_gate_loses_its_turn_instead_of_holding_the_line_for_good():
    # 4 queue in a 0.8 m gate (places 1 m apart, 0.2 persons/s); once all four are in line
    # the second is put 2 m behind the line's end (a push out of the gate): the third and
    # fourth now stand in the gate between it and its place, on their own places. It used
    # to stay second for good, the line waiting for it (JuPedSim's queues_waiting scene:
    # 2 of 20 visitors never served in 4 of 8 seeds); now it takes its turn after them
    from crowdmotion.groups import Rect
    from crowdmotion.stages import Leave, Queue

    scene = cm.Scene(bounds=([0, 0], [10, 20]), obstacles=[cm.Box([0, 12], [4.6, 15]), cm.Box([5.4, 12], [10, 15])])
    sim = rvo.Simulator(scene, time_step=0.25)
    ids = sim.add_agents([[5, 8], [5, 7], [5, 6], [5, 5]], [[5, 18]] * 4, radius=0.2)
    sim.set_route(ids, [Queue([5.0, 14.5], rate=0.2, direction=[0.0, -1.0], spacing=1.0, name="gate"),
                        Leave(Rect([3.0, 18.0], [7.0, 20.0]), name="out")])
    queue = sim.journeys.queues[0]
    pushed = None
    for _ in range(400):  # 100 s
        sim.step()
        if pushed is None and len(queue.members) == 4 and queue.serving:
            pushed = queue.members[1]
            sim.place([pushed], [[5.0, queue.slots[3][1] - 2.0]])
        if not sim.active.any():
            break
    assert pushed is not None
    served = [a for a, _, _ in queue.served]
    assert len(served) == 4 and not queue.members, (served, queue.members)
    assert served[-1] == pushed, "the one pushed out takes its turn behind those now before it"
    released = np.array([r for _, _, r in queue.served])
    assert np.diff(released).min() >= 5.0 - 1e-9 and released[-1] < 40.0, released
