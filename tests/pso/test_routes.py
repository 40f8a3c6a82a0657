"""PSO swarms on routes, as a user writes them: fly to a square, choose an exit, leave."""

import numpy as np
import pytest

from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

SQUARE = """
name = "swarm_square_then_east"
method = "pso"
seed = 1

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]

[[groups]]
name = "swarm"
count = 10
radius = 0.3
max_speed = 2.9
spawn = { shape = "rect", lower = [1.0, 6.0], upper = [6.0, 14.0] }

[[groups.route]]
kind = "goto"
name = "square"
area = { shape = "rect", lower = [18.0, 8.0], upper = [22.0, 12.0] }

[[groups.route]]
kind = "leave"
name = "east"
area = { shape = "rect", lower = [38.0, 8.0], upper = [40.0, 12.0] }

[pso]
iterations = 300
v_max = [0.5, 0.5]
"""


def test_a_swarm_flies_to_the_square_then_leaves_by_the_east_exit():
    result = run_scenario(parse_scenario(SQUARE), progress=False)
    traj, s = result.trajectories, result.summary
    assert traj.metadata["stages"]["swarm"] == [
        {"id": 0, "path": "route[0]", "kind": "goto", "name": "square"},
        {"id": 1, "path": "route[1]", "kind": "leave", "name": "east"}]
    # the stage per frame: the square first, then the exit, never back; -1 once gone
    assert traj.stage.shape == traj.positions.shape[:2]
    for i in range(10):
        here = traj.stage[traj.active[:, i], i]
        assert here[0] == 0 and here[-1] == 1 and np.all(np.diff(here) >= 0)
        assert np.all(traj.stage[~traj.active[:, i], i] == -1)
    turn = int(np.flatnonzero((traj.stage == 1).any(axis=1))[0])
    centre = traj.positions[turn - 1].mean(axis=0)
    assert 18.0 <= centre[0] <= 22.0 and 8.0 <= centre[1] <= 12.0, "it turned for the exit once at the square"
    # all leave, one by one at the exit, each from beside it
    assert not traj.active[-1].any()
    last = np.array([traj.positions[np.flatnonzero(traj.active[:, i])[-1], i] for i in range(10)])
    assert np.all(np.abs(last - [39.0, 10.0]).max(axis=1) < 2.5), last
    gone = [int(np.flatnonzero(~traj.active[:, i])[0]) for i in range(10)]
    assert len(set(gone)) > 1, "the exit empties the swarm particle by particle"
    j = s["journeys"]
    assert j["exits"]["east"]["left"] == 1 and j["finished"] == 1  # the swarm is one walker
    assert [row["reached"] for row in j["stages"]["swarm"]] == [1, 1]
    assert s["arrival_rate"] == 1.0
    assert s["agent_agent_overlaps"] == 0 and s["agent_obstacle_penetrations"] == 0


def test_a_swarm_chooses_the_nearer_exit():
    text = SQUARE.replace('''[[groups.route]]
kind = "leave"
name = "east"
area = { shape = "rect", lower = [38.0, 8.0], upper = [40.0, 12.0] }''', '''[[groups.route]]
kind = "choose"
by = "nearest"
among = [
  { kind = "leave", name = "north", area = { shape = "rect", lower = [18.0, 19.0], upper = [22.0, 20.0] } },
  { kind = "leave", name = "east", area = { shape = "rect", lower = [38.0, 8.0], upper = [40.0, 12.0] } },
]''')
    result = run_scenario(parse_scenario(text), progress=False)
    traj = result.trajectories
    assert set(np.unique(traj.stage)) == {-1, 0, 2}  # square, then north (ids: 1 choose, 2 north, 3 east)
    assert not traj.active[-1].any()
    assert result.summary["journeys"]["exits"] == {"north": result.summary["journeys"]["exits"]["north"]}


@pytest.mark.parametrize("stage,kind", [('kind = "wait"\ntime = 2.0', "wait"),
                                        ('kind = "queue"\nhead = [30.0, 10.0]\ndirection = [-1.0, 0.0]\nrate = 1.0',
                                         "queue")])
def test_validate_refuses_wait_and_queue_for_a_swarm_naming_the_stage(stage, kind):
    text = SQUARE.replace('kind = "goto"\nname = "square"\narea = { shape = "rect", lower = [18.0, 8.0], '
                          'upper = [22.0, 12.0] }', stage)
    with pytest.raises(ScenarioError, match=rf"groups.0.route.0 \(group 'swarm'\): a '{kind}' stage, but method "
                                            rf"'pso' follows only goto, choose, leave stages"):
        parse_scenario(text)


def test_a_route_area_whose_centre_is_covered_is_refused():
    text = SQUARE.replace("bounds = [[0.0, 0.0], [40.0, 20.0]]",
                          'bounds = [[0.0, 0.0], [40.0, 20.0]]\nobstacles = [{ shape = "circle", center = [20.0, 10.0], '
                          'radius = 1.0 }]')
    with pytest.raises(ScenarioError, match=r"route.0 \(goto 'square'\) area: its centre \[20.0, 10.0\], where the "
                                            r"swarm gathers, is covered"):
        parse_scenario(text)


BRANCHES = """
name = "swarm branches"
method = "pso"
seed = 1

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]

[[groups]]
name = "swarm"
count = 10
radius = 0.3
spawn = { shape = "rect", lower = [2.0, 8.0], upper = [6.0, 12.0] }
route = [
  { kind = "choose", by = "nearest", among = [
    [ { kind = "goto", name = "square", area = { shape = "rect", lower = [16.0, 8.0], upper = [20.0, 12.0] } },
      { kind = "leave", name = "east", area = { shape = "rect", lower = [37.0, 8.0], upper = [40.0, 12.0] } } ],
    [ { kind = "goto", name = "far square", area = { shape = "rect", lower = [30.0, 8.0], upper = [34.0, 12.0] } },
      { kind = "leave", name = "north", area = { shape = "rect", lower = [18.0, 17.0], upper = [22.0, 20.0] } } ],
  ] },
]

[pso]
v_max = [0.5, 0.5]
"""


def test_a_swarm_takes_the_branch_whose_first_place_is_nearer_and_follows_it_out():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # v_max above max_speed: not the point here
        result = run_scenario(parse_scenario(BRANCHES), progress=False)
    summary = result.summary
    assert summary["agent_agent_overlaps"] == 0 and summary["agent_obstacle_penetrations"] == 0
    rows = summary["journeys"]["stages"]["swarm"]
    assert rows[0]["chosen"] == [1, 0] and [r["reached"] for r in rows[1:]] == [1, 1, 0, 0]
    assert list(summary["journeys"]["exits"]) == ["east"] and summary["journeys"]["finished"] == 1
    assert not result.trajectories.active_mask[-1].any(), "every particle left by the east exit"
