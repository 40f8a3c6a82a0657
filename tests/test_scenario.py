"""Scenario files: errors name the field and the value; nothing executes."""

import numpy as np
import pytest

from crowdmotion.scenario import ScenarioError, parse_scenario, run_scenario

GOOD = """
name = "t"
method = "mdp"
seed = 1
[scene]
bounds = [[0, 0], [10, 10]]
obstacles = [{ shape = "circle", center = [5, 5], radius = 1 }]
[[groups]]
name = "g"
count = 4
spawn = { shape = "rect", lower = [0.5, 0.5], upper = [3, 3] }
goal = { shape = "point", position = [9, 9] }
[mdp]
max_steps = 30
"""


def test_good_scenario_builds():
    sc = parse_scenario(GOOD)
    assert sc.scene.dim == 2 and sc.groups[0].count == 4 and sc.params.max_steps == 30


@pytest.mark.parametrize("old,new,field,value", [
    ("count = 4", "count = -3", "groups.0.count", "-3"),
    ("radius = 1 }", "radius = nan }", "scene.obstacles.0.circle.radius", "nan"),
    ("max_steps = 30", "max_stepz = 30", "mdp.max_stepz", "30"),
    ('method = "mdp"', 'method = "magic"', "method", "magic"),
    ("position = [9, 9]", "position = [9, 9, 9]", "groups.0.goal", "[9.0, 9.0, 9.0]"),
    ("bounds = [[0, 0], [10, 10]]", "bounds = [[0, 0], [-10, 10]]", "scene", "-10"),
])
def test_errors_name_field_and_value(old, new, field, value):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(GOOD.replace(old, new))
    assert field in str(e.value) and value in str(e.value)


def test_not_toml():
    with pytest.raises(ScenarioError, match="not valid TOML"):
        parse_scenario("name = ")


def test_cell_size_too_small_is_named_on_load():
    # refused on load (so by `validate`), not only once the run starts
    with pytest.raises(ScenarioError, match="mdp.cell_size 0.1"):
        parse_scenario(GOOD.replace("max_steps = 30", "max_steps = 30\ncell_size = 0.1"))


RVO = """
name = "street"
method = "rvo"
[scene]
bounds = [[0, 0], [30, 10]]
[[groups]]
name = "a"
count = 5
personality = "A+"
spawn = { shape = "rect", lower = [1, 1], upper = [5, 9] }
goal = { shape = "rect", lower = [25, 1], upper = [29, 9] }
[[groups]]
name = "ring"
count = 6
personality = { distribution = "trig", theta_low = [0, 0, 0, 0, -1.5], theta_high = [0, 0, 0, 0, 1.5] }
spawn = { shape = "ring", center = [15, 5], radius = 3 }
goal = { shape = "antipodal", center = [15, 5] }
[rvo]
max_steps = 50
goal_assignment = "shift"
"""


def test_rvo_scenario_with_personalities_ring_and_antipodal_goal():
    sc = parse_scenario(RVO)
    assert sc.params.max_steps == 50 and sc.params.goal_assignment == "shift"
    ring = sc.groups[1]
    assert np.allclose(np.linalg.norm(ring.spawn.points - [15, 5], axis=1), 3)
    assert np.allclose(ring.goal.points, 2 * np.array([15, 5]) - ring.spawn.points)
    assert sc.groups[0].attributes["personality"] == "A+"


def _refused(text: str, words, run: bool = False) -> None:
    """The scenario is refused (on loading, or with ``run`` at the latest when run) with a
    message containing every one of ``words``."""
    with pytest.raises(ScenarioError) as e:
        sc = parse_scenario(text)
        if run:
            run_scenario(sc, progress=False)
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize("old,new,words", [
    ('personality = "A+"', 'personality = "B+"', ["groups.0.personality", "unknown personality trait 'B+'"]),
    ('personality = "A+"', "personality = [0, 0, 3, 0, 0]", ["groups.0.personality", "ψE must lie in [-1, 1]"]),
    ("max_steps = 50", "max_steps = 0", ["rvo.max_steps", "0"]),
    ('goal = { shape = "antipodal", center = [15, 5] }', 'goal = { shape = "ring", center = [1, 1], radius = 1 }',
     ["groups.1.goal", "ring is a spawn shape"]),
    ('spawn = { shape = "rect", lower = [1, 1], upper = [5, 9] }', 'spawn = { shape = "disc", center = [3, 5], radius = 1 }\ngoal2 = 1',
     ["groups.0.goal2"]),
])
def test_rvo_scenario_errors_name_the_field(old, new, words):
    _refused(RVO.replace(old, new), words)


PSO = """
method = "pso"
seed = 3
[scene]
bounds = [[-40, -40], [40, 40]]
obstacles = [{ shape = "circle", center = [10, 0], radius = 2 }]
[[groups]]
name = "s"
count = 12
spawn = { shape = "rect", lower = [-30, -30], upper = [30, 30] }
goal = { shape = "point", position = [0, 0] }
[pso]
iterations = 80
v_max = [0.5, 0.5]
[pso.obstacle_field]
count = 4
radius = 1.5
layout = "grouped"
"""


def test_pso_scenario_block_is_the_api_params():
    from crowdmotion.pso import PSOParams

    sc = parse_scenario(PSO)
    assert isinstance(sc.params, PSOParams)
    assert sc.params.iterations == 80 and sc.params.obstacle_field.layout == "grouped"
    result = run_scenario(sc, progress=False)
    assert result.summary["generated_obstacles"] == 4
    assert len(result.extras.scene.obstacles) == 5
    assert result.summary["agent_obstacle_penetrations"] == 0


@pytest.mark.parametrize("old,new,words", [
    ("iterations = 80", "iterations = 0", ["pso.iterations", "greater than 0", "got 0"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5, -1]", ["pso.v_max.1", "got -1"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5]\nthreshold = nan", ["pso.threshold"]),
    ('layout = "grouped"', 'layout = "ring"', ["pso.obstacle_field.layout", "'ring'"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5, 0.5]\nconstriction = true", ["pso", "c1 + c2 > 4"]),
    ('obstacles = [{ shape = "circle", center = [10, 0], radius = 2 }]',
     'obstacles = [{ shape = "polygon", vertices = [[5, 5], [8, 5], [6, 9]] }]', ["scene.obstacles.0 is a polygon"]),
    ("position = [0, 0]", "position = [10, 0.5]", ["covered by an obstacle"]),
])
def test_pso_scenario_errors_name_the_field(old, new, words):
    _refused(PSO.replace(old, new), words, run=True)


FORMATION = """
method = "formation"
seed = 2
[scene]
bounds = [[0, -10], [40, 10]]
obstacles = [{ shape = "circle", center = [20, 0.4], radius = 1 }]
[[groups]]
name = "squad"
count = 9
radius = 0.3
spawn = { shape = "point", position = [5, 0] }
goal = { shape = "point", position = [33, 0] }
formation = { kind = "block", rows = 3, cols = 3, spacing = 1.2 }
[formation]
max_steps = 800
field_range = 1.5
"""


def test_formation_scenario_runs_and_reports_the_formation():
    from crowdmotion.formation import FormationParams

    sc = parse_scenario(FORMATION)
    assert isinstance(sc.params, FormationParams) and sc.params.field_range == 1.5
    s = run_scenario(sc, progress=False).summary
    assert s["agent_agent_overlaps"] == 0 and s["agent_obstacle_penetrations"] == 0
    assert s["all_recovered"] and s["formation"]["squad"]["edge_length_error_mean"] < 0.02


@pytest.mark.parametrize("old,new,words", [
    ("count = 9", "count = 10", ["group 'squad'", "count = 10 but its formation template (block) holds 9"]),
    ("position = [33, 0]", "position = [20, 0.4]", ["goal [20.0, 0.4] is inside an obstacle"]),
    ("rows = 3, cols", "rows = 0, cols", ["groups.0.formation.block.rows", "got 0"]),
    ('kind = "block", rows = 3, cols = 3, spacing = 1.2', 'kind = "hexagon"', ["groups.0.formation", "hexagon"]),
    ("field_range = 1.5", "field_range = -1", ["formation.field_range", "got -1"]),
    ("field_range = 1.5", "relink_ratio = 3.0", ["relink_ratio 3.0 must not exceed tear_ratio"]),
    ("bounds = [[0, -10], [40, 10]]", "bounds = [[0, -10, 0], [40, 10, 5]]", ["not 3D like the scene"]),
    ("spacing = 1.2", "spacing = 0.4", ["overlap at the start"]),
])
def test_formation_scenario_errors_name_the_field(old, new, words):
    _refused(FORMATION.replace(old, new), words)


def test_remove_on_arrival_is_one_option_in_mdp_and_rvo_and_the_old_mdp_name_still_reads():
    from crowdmotion.mdp import MDPParams
    from crowdmotion.rvo import RVOParams

    assert "remove_on_arrival" in MDPParams.model_fields and "remove_on_arrival" in RVOParams.model_fields
    assert MDPParams(despawn=True) == MDPParams(remove_on_arrival=True)
    sc = parse_scenario(GOOD.replace("max_steps = 30", "max_steps = 30\nremove_on_arrival = true"))
    assert sc.params.remove_on_arrival is True
