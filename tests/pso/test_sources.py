"""PSO swarms that enter late, as a user writes them: a swarm comes in whole at its time."""

import numpy as np
import pytest

from crowdmotion.metrics import collision_audit
from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

YARD = """
name = "late_swarm"
method = "pso"
seed = 4

[scene]
bounds = [[-20.0, -12.0], [20.0, 12.0]]
obstacles = [{ shape = "circle", center = [0.0, 3.0], radius = 2.0 }]

[[groups]]
name = "west"
count = 12
radius = 0.3
max_speed = 2.9
spawn = { shape = "rect", lower = [-18.0, -6.0], upper = [-12.0, 6.0] }
goal = { shape = "point", position = [14.0, 1.0] }

[[groups]]
name = "east"
count = 12
radius = 0.3
max_speed = 2.9
spawn = { shape = "rect", lower = [12.0, -6.0], upper = [18.0, 6.0] }
goal = { shape = "point", position = [-14.0, -1.0] }
enter = { start = 5.0 }

[pso]
iterations = 200
"""


def test_a_pso_swarm_entering_at_5_s_is_absent_before_and_reaches_its_goal():
    scenario = parse_scenario(YARD)
    result = run_scenario(scenario, progress=False)
    traj, summary = result.trajectories, result.summary
    east = traj.group == "east"
    came = np.argmax(traj.active_mask[:, east], axis=0)
    assert np.all(came == came[0]), "the swarm comes in whole"
    assert traj.times[came[0]] >= 5.0 - 1e-9 and not traj.active_mask[traj.times < 5.0 - 1e-9][:, east].any()
    assert traj.active_mask[:, ~east].all(), "the other swarm is there from the start"
    assert summary["entry"]["east"] == {"entered": 12, "waiting_at_end": 0, "mean_delay_s": 0.0, "max_delay_s": 0.0}
    assert summary["groups_gathered"] == {"west": True, "east": True} and summary["arrival_rate"] == 1.0
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()  # 0 overlaps, 0 penetrations


def test_two_swarms_on_one_spawn_the_later_waits_off_scene_until_the_first_has_cleared_it():
    text = YARD.replace("spawn = { shape = \"rect\", lower = [-18.0, -6.0], upper = [-12.0, 6.0] }",
                        "spawn = { shape = \"rect\", lower = [12.0, -6.0], upper = [18.0, 6.0] }").replace(
        "position = [14.0, 1.0]", "position = [-14.0, 4.0]").replace("enter = { start = 5.0 }", "enter = { start = 0.5 }")
    scenario = parse_scenario(text)
    result = run_scenario(scenario, progress=False)
    traj, summary = result.trajectories, result.summary
    row = summary["entry"]["east"]
    assert row["entered"] == 12 and row["max_delay_s"] > 0, "it waited for the spawn to clear"
    east = traj.group == "east"
    came = int(np.argmax(traj.active_mask[:, east][:, 0]))
    assert traj.times[came] == pytest.approx(0.5 + row["max_delay_s"], abs=traj.dt)
    assert summary["groups_gathered"] == {"west": True, "east": True}
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()


@pytest.mark.parametrize("enter,field", [
    ("enter = { rate = 2.0 }", "rate"),
    ("enter = { start = 1.0, end = 5.0 }", "end"),
    ("enter = { times = [1.0] }", "times"),
    ('enter = { entrances = [{ shape = "point", position = [15.0, 0.0] }] }', "entrances"),
])
def test_validate_refuses_a_swarm_entering_over_time_naming_the_field(enter, field):
    text = YARD.replace("enter = { start = 5.0 }", enter)
    if field == "entrances":
        text = text.replace('spawn = { shape = "rect", lower = [12.0, -6.0], upper = [18.0, 6.0] }\n', "")
    with pytest.raises(ScenarioError, match=rf"groups.1.enter.{field} \(group 'east'\): a PSO swarm enters as one "
                                            rf"unit, all at once at its spawn: give enter = {{ start = s }} only"):
        parse_scenario(text)


def test_validate_refuses_a_late_swarm_beside_a_moving_target():
    text = YARD.replace('goal = { shape = "point", position = [14.0, 1.0] }',
                        'goal = { shape = "moving", times = [0.0, 20.0], positions = [[14.0, 1.0], [14.0, -5.0]] }')
    with pytest.raises(ScenarioError, match=r"group 'east' \(groups.1\) enter: a swarm entering late needs fixed goals"):
        parse_scenario(text)


def test_a_late_swarm_s_time_to_goal_counts_from_its_entry():
    result = run_scenario(parse_scenario(YARD), progress=False)
    run, summary = result.extras, result.summary
    east = result.trajectories.group == "east"
    arrived_s = run.swarm_run.arrival_iteration[east] * run.swarm_run.iteration_time
    assert np.all(run.entered_at[east] == 5.0) and np.all(arrived_s > 5.0)
    assert summary["time_to_goal_by_group_s"]["east"] == pytest.approx(np.mean(arrived_s - 5.0))
