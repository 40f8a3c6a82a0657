"""MDP groups on routes, as a user writes them: go to a room, wait, choose, leave."""

import numpy as np
import pytest

from crowdmotion.metrics import collision_audit
from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

ROOM = """
name = "room_then_door"
method = "mdp"
seed = 3

[scene]
bounds = [[0.0, 0.0], [24.0, 10.0]]
obstacles = [
  { shape = "box", lower = [16.0, 0.0], upper = [16.5, 4.0] },
  { shape = "box", lower = [16.0, 6.0], upper = [16.5, 10.0] },
]

[[groups]]
name = "visitors"
count = 12
radius = 0.25
spawn = { shape = "rect", lower = [0.5, 0.5], upper = [5.0, 9.5] }

[[groups.route]]
kind = "goto"
name = "room"
area = { shape = "rect", lower = [9.0, 2.0], upper = [13.0, 8.0] }

[[groups.route]]
kind = "wait"
time = 3.0

[[groups.route]]
kind = "leave"
name = "door"
area = { shape = "rect", lower = [22.5, 4.0], upper = [24.0, 6.0] }
"""


def test_an_mdp_group_walks_to_a_room_waits_3_s_then_leaves_by_the_door():
    scenario = parse_scenario(ROOM)
    result = run_scenario(scenario, progress=False)
    traj, summary = result.trajectories, result.summary
    audit = collision_audit(traj, scenario.scene)
    assert audit.clean, audit.as_dict()  # 0 overlaps, 0 penetrations
    journeys = summary["journeys"]
    rows = {row["name"]: row for row in journeys["stages"]["visitors"]}
    assert rows["room"]["reached"] == rows["wait 3 s"]["reached"] == rows["door"]["reached"] == 12
    step = result.extras.walkers.dt  # a wait lasts whole steps of the grid
    assert 3.0 <= rows["wait 3 s"]["mean_time_s"] <= rows["wait 3 s"]["max_time_s"] < 3.0 + step + 1e-9
    assert journeys["exits"]["door"]["left"] == 12 and summary["arrival_rate"] == 1.0
    assert not traj.active_mask[-1].any(), "every agent left the scene"
    # the stage per frame: room (0), then waiting (1), then the door (2), then gone (-1)
    st = traj.stage
    assert st is not None and st.shape == (traj.n_frames, 12)
    for i in range(12):
        seen = st[:, i][np.r_[True, np.diff(st[:, i]) != 0]]
        assert seen.tolist() == [0, 1, 2, -1], (i, seen)
        assert np.all(st[~traj.active_mask[:, i], i] == -1)
    # waiting agents stand in the room; they leave through the door's cells
    waiting = st == 1
    pos = traj.positions[waiting]
    assert np.all((pos >= [9.0 - 0.36, 2.0 - 0.36]) & (pos <= [13.0 + 0.36, 8.0 + 0.36]))


def test_each_area_is_solved_once_even_when_the_route_comes_back_to_it(monkeypatch):
    import crowdmotion.mdp.simulation as sim

    solved = []
    real = sim.solve_field

    def counted(occupancy, goals, params, previous=None):
        solved.append(np.unique(np.asarray(goals), axis=0).tobytes())
        return real(occupancy, goals, params, previous)

    monkeypatch.setattr(sim, "solve_field", counted)
    text = ROOM.replace('[[groups.route]]\nkind = "leave"', """[[groups.route]]
kind = "goto"
name = "hall"
area = { shape = "rect", lower = [1.0, 1.0], upper = [5.0, 9.0] }

[[groups.route]]
kind = "wait"
time = 1.0

[[groups.route]]
kind = "goto"
name = "room again"
area = { shape = "rect", lower = [9.0, 2.0], upper = [13.0, 8.0] }

[[groups.route]]
kind = "leave\"""")
    result = run_scenario(parse_scenario(text), progress=False)
    assert result.summary["journeys"]["exits"]["door"]["left"] == 12
    # room (the group's first place), hall, door: three areas, three solves, none twice
    assert len(solved) == 3 and len(set(solved)) == 3
    assert result.summary["route_fields_solved"] == 2  # hall and door; the room was the group's goal


TWO_EXITS = """
name = "two_exits"
method = "mdp"
seed = 1

[scene]
bounds = [[0.0, 0.0], [30.0, 10.0]]

[[groups]]
name = "evacuees"
count = 20
radius = 0.25
spawn = { shape = "rect", lower = [8.0, 1.0], upper = [22.0, 9.0] }

[[groups.route]]
kind = "choose"
by = "nearest"
among = [
  { kind = "leave", name = "west", area = { shape = "rect", lower = [0.0, 4.0], upper = [1.0, 6.0] } },
  { kind = "leave", name = "east", area = { shape = "rect", lower = [29.0, 4.0], upper = [30.0, 6.0] } },
]
"""


def test_mdp_evacuees_choose_the_nearer_exit_and_all_leave():
    scenario = parse_scenario(TWO_EXITS)
    result = run_scenario(scenario, progress=False)
    assert collision_audit(result.trajectories, scenario.scene).clean
    exits = result.summary["journeys"]["exits"]
    assert exits["west"]["left"] + exits["east"]["left"] == 20 and exits["west"]["left"] > 0 and exits["east"]["left"] > 0
    start_x = result.trajectories.positions[0, :, 0]
    took = result.trajectories.stage.max(axis=0)  # choose = 0, west = 1, east = 2
    assert np.all(took[start_x < 14.0] == 1) and np.all(took[start_x > 16.0] == 2)


def test_validate_refuses_a_queue_stage_for_an_mdp_group_naming_it():
    text = ROOM.replace('kind = "wait"\ntime = 3.0', 'kind = "queue"\nname = "desk"\nhead = [12.0, 5.0]\n'
                                                       'direction = [-1.0, 0.0]\nrate = 0.5')
    with pytest.raises(ScenarioError, match=r"groups.0.route.1 \(group 'visitors'\): a 'queue' stage, but method "
                                            r"'mdp' follows only goto, wait, choose, leave stages; method 'rvo' "
                                            r"follows queue stages"):
        parse_scenario(text)


def test_twenty_grid_agents_split_30_70_between_the_fountain_route_and_the_west_exit():
    # a choose whose first option is a whole route (goto, wait, leave east): 6 of 20 take it
    from tests.test_journeys import SPLIT

    text = SPLIT.replace("METHOD", "mdp").replace("COUNT", "20").replace("enter = { rate = 2.0 }\n", "")
    result = run_scenario(parse_scenario(text), progress=False)
    summary = result.summary
    assert summary["agent_agent_overlaps"] == 0 and summary["agent_obstacle_penetrations"] == 0
    journeys = summary["journeys"]
    assert journeys["stages"]["walkers"][0]["chosen"] == [6, 14]
    assert journeys["exits"]["east"]["left"] == 6 and journeys["exits"]["west"]["left"] == 14
    assert journeys["finished"] == 20
