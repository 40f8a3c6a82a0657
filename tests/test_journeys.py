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


def test_entry_times_at_a_rate_from_a_start():
    assert entry_times({"rate": 4.0, "start": 10.0}, 3).tolist() == [10.0, 10.25, 10.5]
    assert entry_times({"times": [5, 0, 2]}, 3).tolist() == [5.0, 0.0, 2.0]
    assert entry_times(None, 2).tolist() == [0.0, 0.0]


@pytest.mark.parametrize("old,new,message", [
    ("enter = { rate = 2.0 }", "enter = { rate = 2.0, times = [1.0] }", "either rate"),
    ("enter = { rate = 2.0 }", "enter = { times = [1.0, 2.0] }", r"group 'commuters' \(groups.0\): enter.times: 2 time\(s\) for a group of 120"),
    ("enter = { rate = 2.0 }", "enter = { rate = -1.0 }", "groups.0.enter.rate"),
    ('method = "rvo"', 'method = "pso"', r"groups.0.enter \(group 'commuters'\): only method 'rvo' reads a group's enter"),
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
