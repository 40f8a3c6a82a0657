"""MDP groups that enter over time, as a user writes them: a rate, a blocked door, entrances."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion.metrics import collision_audit
from crowdmotion.mdp.adapter import step_seconds
from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

STREAM = """
name = "mdp_stream"
method = "mdp"
seed = 1

[scene]
bounds = [[0.0, 0.0], [20.0, 10.0]]
obstacles = [{ shape = "box", lower = [9.0, 0.0], upper = [10.0, 3.0] }]

[[groups]]
name = "walkers"
count = 20
radius = 0.25
spawn = { shape = "rect", lower = [0.0, 4.0], upper = [1.5, 6.0] }
goal = { shape = "rect", lower = [16.0, 2.0], upper = [20.0, 8.0] }
enter = { rate = 1.0, start = 2.0 }

[mdp]
max_steps = 400
"""


def first_frames(traj) -> np.ndarray:
    """(N,) the first frame each agent is in the scene."""
    return np.argmax(traj.active_mask, axis=0)


def test_mdp_agents_entering_at_1_per_second_all_enter_none_overlap_each_absent_before_its_time():
    scenario = parse_scenario(STREAM)
    result = run_scenario(scenario, progress=False)
    traj, summary, arrivals = result.trajectories, result.summary, result.extras.arrivals
    due = 2.0 + np.arange(20)
    assert np.allclose(arrivals.due, due)
    # the time base is fixed before the run: a step lasts what step_seconds says ahead
    dt = step_seconds(scenario.groups, scenario.params)
    assert arrivals.dt == pytest.approx(dt)
    entered = arrivals.entered_at(result.extras.walker)
    assert np.all(entered >= due - 1e-9), "nobody enters before its time"
    assert np.all(entered < due + dt + 1e-9), "the door is free: each enters at the first step at its time"
    assert np.all(traj.times[first_frames(traj)] >= due - 1e-9), "absent from the trajectories before its time"
    present = traj.active_mask.sum(axis=1)
    assert present[0] == 0 and present[-1] == 20 and np.all(np.diff(present) <= 1), "they come in one by one"
    row = summary["entry"]["walkers"]
    assert row["entered"] == 20 and row["waiting_at_end"] == 0
    assert row["max_delay_s"] == pytest.approx(float(np.max(entered - due)))
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()  # 0 overlaps, 0 penetrations
    assert summary["arrival_rate"] == 1.0


def test_mdp_agents_all_due_at_once_at_a_one_cell_door_enter_one_by_one_as_it_frees():
    text = STREAM.replace('spawn = { shape = "rect", lower = [0.0, 4.0], upper = [1.5, 6.0] }',
                          'spawn = { shape = "point", position = [0.5, 5.0] }').replace(
        "count = 20", "count = 8").replace("enter = { rate = 1.0, start = 2.0 }", "enter = { start = 1.0 }") \
        + 'smoothing = "none"  # cell centres, one frame a step\n'
    scenario = parse_scenario(text)
    result = run_scenario(scenario, progress=False)
    traj, summary = result.trajectories, result.summary
    entered = result.extras.arrivals.entered_at(result.extras.walker)
    assert len(np.unique(entered)) == 8, "one at a time through a door one cell wide"
    row = summary["entry"]["walkers"]
    assert row["entered"] == 8 and row["max_delay_s"] > 0, "the door was taken: the later ones waited"
    door = traj.positions[first_frames(traj), np.arange(8)]
    assert np.allclose(door, door[0]), "every one came in at the door"
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()


TWO_DOORS = STREAM.replace('spawn = { shape = "rect", lower = [0.0, 4.0], upper = [1.5, 6.0] }\n', "").replace(
    "enter = { rate = 1.0, start = 2.0 }", """enter = { rate = 2.0, end = 10.0, weights = [3, 1], entrances = [
    { shape = "rect", lower = [0.0, 6.0], upper = [1.5, 9.0] },
    { shape = "rect", lower = [4.0, 0.0], upper = [6.0, 1.0] } ] }""") + 'smoothing = "none"\n'


def test_an_mdp_group_with_two_entrances_uses_both_in_the_given_proportions_and_none_overlap():
    scenario = parse_scenario(TWO_DOORS)
    result = run_scenario(scenario, progress=False)
    traj, summary, arrivals = result.trajectories, result.summary, result.extras.arrivals
    assert np.bincount(arrivals.entrance).tolist() == [15, 5], "weights 3 : 1 of 20"
    came = traj.positions[first_frames(traj), np.arange(20)]
    west, south = arrivals.entrance == 0, arrivals.entrance == 1
    assert cm.Rect([0.0, 6.0], [1.5, 9.0]).contains(came[west]).all()
    assert cm.Rect([4.0, 0.0], [6.0, 1.0]).contains(came[south]).all()
    assert [d["entered"] for d in summary["entry"]["walkers"]["entrances"]] == [15, 5]
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()


def test_mdp_agents_on_a_route_begin_it_when_they_enter():
    text = STREAM.replace('goal = { shape = "rect", lower = [16.0, 2.0], upper = [20.0, 8.0] }\n', "").replace(
        "count = 20", "count = 6") + """
[[groups.route]]
kind = "goto"
name = "hall"
area = { shape = "rect", lower = [12.0, 4.0], upper = [14.0, 8.0] }

[[groups.route]]
kind = "leave"
name = "exit"
area = { shape = "rect", lower = [19.0, 4.0], upper = [20.0, 6.0] }
"""
    scenario = parse_scenario(text.replace("[mdp]\nmax_steps = 400\n", "") + "\n[mdp]\nmax_steps = 400\n")
    result = run_scenario(scenario, progress=False)
    traj, summary = result.trajectories, result.summary
    came = first_frames(traj)
    for i in range(6):
        assert (traj.stage[:came[i], i] == -1).all() and traj.stage[came[i], i] == 0, "the hall, from entry on"
    assert summary["journeys"]["exits"]["exit"]["left"] == 6 and summary["entry"]["walkers"]["entered"] == 6
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()


def test_validate_refuses_an_mdp_entrance_outside_the_scene_naming_it():
    bad = TWO_DOORS.replace("lower = [4.0, 0.0], upper = [6.0, 1.0]", "lower = [4.0, -1.0], upper = [6.0, 1.0]")
    with pytest.raises(ScenarioError, match=r"enter.entrances.1: rect .* reaches outside scene.bounds"):
        parse_scenario(bad)


def test_validate_warns_when_mdp_agents_are_due_after_the_run_ends():
    # 20 at 1 per second from 2 s: the last is due at 21 s, after 10 steps
    with pytest.warns(UserWarning, match=r"enter: \d+ of 20 agents are due after the run ends at .* \(\[mdp\] "
                                         r"max_steps x its step time\), the last at 21 s"):
        parse_scenario(STREAM.replace("max_steps = 400", "max_steps = 10"))
