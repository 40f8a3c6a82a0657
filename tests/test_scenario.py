"""Scenario files: errors name the field and the value; nothing executes."""

import pytest

from crowdmotion.scenario import ScenarioError, parse_scenario

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


def test_cell_size_too_small_is_named():
    from crowdmotion.scenario import run_scenario

    sc = parse_scenario(GOOD.replace("max_steps = 30", "max_steps = 30\ncell_size = 0.1"))
    with pytest.raises(ValueError, match="mdp.cell_size 0.1"):
        run_scenario(sc, progress=False)
