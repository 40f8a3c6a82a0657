"""Formations on routes, as a user writes them: goto, wait, choose and leave as one unit."""

import numpy as np
import pytest

from crowdmotion.metrics import collision_audit, kabsch_rms
from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

SQUARE = """
name = "parade"
method = "formation"
seed = 3

[scene]
bounds = [[0.0, 0.0], [60.0, 30.0]]
obstacles = [{ shape = "circle", center = [20.0, 21.0], radius = 1.5 }]

[[groups]]
name = "band"
count = 12
radius = 0.3
spawn = { shape = "point", position = [5.0, 15.0] }
formation = { kind = "block", rows = 3, cols = 4, spacing = 1.2 }

[[groups.route]]
kind = "goto"
name = "square"
area = { shape = "disc", center = [30.0, 15.0], radius = 3.0 }

[[groups.route]]
kind = "wait"
time = 5.0

[[groups.route]]
kind = "choose"
by = "nearest"
among = [
  { kind = "leave", name = "east", area = { shape = "rect", lower = [55.0, 12.0], upper = [59.5, 18.0] } },
  { kind = "leave", name = "west", area = { shape = "rect", lower = [0.5, 2.0], upper = [3.0, 8.0] } },
]

[formation]
max_steps = 3000
"""


def test_a_formation_of_12_walks_to_the_square_waits_5_s_then_leaves_by_the_east_exit_in_shape():
    result = run_scenario(parse_scenario(SQUARE), progress=False)
    traj, summary = result.trajectories, result.summary
    audit = collision_audit(traj, parse_scenario(SQUARE).scene)
    assert audit.clean, audit.as_dict()  # 0 overlaps, 0 penetrations
    stages = summary["journeys"]["stages"]["band"]
    by_name = {row["name"]: row for row in stages}
    assert by_name["square"]["reached"] == 1 and by_name["wait 5 s"]["reached"] == 1
    assert by_name["wait 5 s"]["mean_time_s"] == pytest.approx(5.0, abs=traj.dt + 1e-9)
    assert summary["journeys"]["exits"]["east"]["left"] == 1 and "west" not in summary["journeys"]["exits"]
    assert summary["journeys"]["finished"] == 1
    # the stage of each agent per frame: the whole band in one stage at a time, then gone
    st = traj.stage
    assert st is not None and np.all(st == st[:, :1])
    ids = [row["id"] for row in stages]
    seen = [int(s) for s in dict.fromkeys(st[:, 0].tolist())]
    assert seen == [ids[0], ids[1], ids[3], -1]  # square, wait, east exit (among[0]), left
    assert not traj.active[-1].any()
    assert result.extras.snapshot(len(result.extras.frames) - 1) == []  # figures draw no band that left
    # it keeps its shape between stages: when it begins to wait and when it sets off for the exit
    rest = result.extras.simulator.groups[0].mesh.rest  # the block as it set out
    waiting = np.flatnonzero(st[:, 0] == ids[1])
    for f in (waiting[0], waiting[-1]):
        pos = traj.positions[f]
        assert np.linalg.norm(pos.mean(axis=0) - [30.0, 15.0]) < 3.0
        assert kabsch_rms(pos, rest) < 0.15


def test_validate_refuses_a_queue_stage_for_a_formation_naming_it():
    text = SQUARE.replace('''[[groups.route]]
kind = "wait"
time = 5.0''', '''[[groups.route]]
kind = "queue"
name = "gate"
head = [40.0, 15.0]
direction = [-1.0, 0.0]
rate = 0.5''')
    with pytest.raises(ScenarioError, match=r"groups\.0\.route\.1 \(group 'band'\): a 'queue' stage, but method "
                                            r"'formation' follows only goto, wait, choose, leave stages; "
                                            r"method 'rvo' follows queue stages"):
        parse_scenario(text)


def test_a_formation_given_a_queue_in_python_is_refused_naming_the_stage():
    from crowdmotion import Scene, formation
    from crowdmotion.groups import Group, Points, Rect
    from crowdmotion.stages import Leave, Queue

    route = [Queue([20.0, 10.0], rate=0.5, direction=[-1.0, 0.0], name="gate"), Leave(Rect([38, 8], [40, 12]))]
    group = Group("band", 4, Points([[5.0, 10.0]]), (30.0, 10.0), radius=0.3,
                  attributes={"formation": {"kind": "block", "rows": 2, "cols": 2}, "route": route})
    with pytest.raises(ValueError, match=r"route.0 \(queue 'gate'\): a formation does not queue"):
        formation.run(Scene(((0, 0), (40, 20))), [group], {"max_steps": 10}, np.random.default_rng(0))


# ---- sources: a formation enters as one unit -----------------------------------------------
TWO_BANDS = """
name = "bands"
method = "formation"
seed = 3

[scene]
bounds = [[0.0, 0.0], [40.0, 20.0]]

[[groups]]
name = "first"
count = 6
radius = 0.3
spawn = { shape = "point", position = [4.0, 10.0] }
goal = { shape = "disc", center = [32.0, 5.0], radius = 2.5 }
formation = { kind = "block", rows = 2, cols = 3, spacing = 1.2 }

[[groups]]
name = "second"
count = 6
radius = 0.3
spawn = { shape = "point", position = [4.0, 10.0] }
goal = { shape = "disc", center = [32.0, 15.0], radius = 2.5 }
formation = { kind = "block", rows = 2, cols = 3, spacing = 1.2 }
enter = { start = 1.0 }

[formation]
max_steps = 1500
"""


def test_a_second_band_on_the_same_spawn_enters_whole_once_the_first_has_cleared_it_and_none_overlap():
    result = run_scenario(parse_scenario(TWO_BANDS), progress=False)
    traj, summary = result.trajectories, result.summary
    sim = result.extras.simulator
    first, second = sim.groups
    assert first.entered_at == 0.0 and second.entered_at > 1.0, "due at 1 s, the spawn still taken"
    delay = summary["entry"]["second"]["max_delay_s"]
    assert delay == pytest.approx(second.entered_at - 1.0) and summary["entry"]["first"]["max_delay_s"] == 0.0
    present = traj.active_mask[:, sim.group_of == 1]
    assert np.all(present == present[:, :1]), "the band comes in whole"
    came = int(np.argmax(present[:, 0]))
    assert came > 0 and traj.times[came] >= second.entered_at - 1e-9, "absent from the outputs before it enters"
    audit = collision_audit(traj, parse_scenario(TWO_BANDS).scene)
    assert audit.clean, audit.as_dict()  # 0 overlaps, 0 penetrations
    assert summary["all_recovered"]


@pytest.mark.parametrize("enter,message", [
    ("enter = { rate = 1.0 }", r"groups.1.enter.rate \(group 'second'\): a formation enters as one unit"),
    ("enter = { start = 1.0, end = 5.0 }", r"groups.1.enter.end \(group 'second'\): a formation enters as one unit"),
])
def test_validate_refuses_a_formation_entering_over_time_naming_the_field(enter, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(TWO_BANDS.replace("enter = { start = 1.0 }", enter))


def test_a_formation_entering_at_4_s_starts_its_route_when_it_enters():
    text = SQUARE.replace('formation = { kind = "block", rows = 3, cols = 4, spacing = 1.2 }\n',
                          'formation = { kind = "block", rows = 3, cols = 4, spacing = 1.2 }\nenter = { start = 4.0 }\n')
    result = run_scenario(parse_scenario(text), progress=False)
    traj, summary = result.trajectories, result.summary
    came = int(np.argmax(traj.active_mask[:, 0]))
    assert traj.times[came] >= 4.0 - 1e-9 and not traj.active_mask[:came].any(), "off-scene until 4 s"
    assert (traj.stage[:came] == -1).all() and (traj.stage[came] == 0).all(), "on its way to the square from entry"
    square = {row["name"]: row for row in summary["journeys"]["stages"]["band"]}["square"]
    assert square["reached"] == 1
    assert summary["journeys"]["exits"]["east"]["left"] == 1 and summary["entry"]["band"]["entered"] == 12
    audit = collision_audit(traj, parse_scenario(text).scene)
    assert audit.clean, audit.as_dict()


def test_a_formation_takes_the_branch_whose_first_place_is_nearer_and_follows_it_in_shape():
    # a choose between two whole routes: the square, a wait and the east exit; or the south-east exit
    route_tables = SQUARE[SQUARE.index("[[groups.route]]"):SQUARE.index("\n\n[formation]")]
    text = SQUARE.replace(route_tables, '''route = [{ kind = "choose", by = "nearest", among = [
  [ { kind = "goto", name = "square", area = { shape = "disc", center = [30.0, 15.0], radius = 3.0 } },
    { kind = "wait", time = 5.0 },
    { kind = "leave", name = "east", area = { shape = "rect", lower = [55.0, 12.0], upper = [59.5, 18.0] } } ],
  { kind = "leave", name = "south-east", area = { shape = "rect", lower = [55.0, 0.5], upper = [59.5, 3.0] } },
] }]''')
    result = run_scenario(parse_scenario(text), progress=False)
    summary = result.summary
    assert collision_audit(result.trajectories, parse_scenario(text).scene).clean
    rows = summary["journeys"]["stages"]["band"]
    assert rows[0]["chosen"] == [1, 0]  # the square (22 m off) is nearer than the south-east exit (51 m)
    assert [r["reached"] for r in rows[1:]] == [1, 1, 1, 0]
    assert rows[2]["mean_time_s"] == pytest.approx(5.0, abs=result.trajectories.dt + 1e-9)
    assert summary["journeys"]["exits"]["east"]["left"] == 1 and summary["journeys"]["finished"] == 1
