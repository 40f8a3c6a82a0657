"""Scenario files: errors name the field and the value; nothing executes."""

import warnings

import crowdmotion as cm
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
    ("iterations = 80", "iterations = 0", ["pso.iterations", "must be more than 0", "got 0"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5, -1]", ["pso.v_max.1", "got -1"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5]\nthreshold = nan", ["pso.threshold"]),
    ('layout = "grouped"', 'layout = "ring"', ["pso.obstacle_field.layout", "'ring'"]),
    ("v_max = [0.5, 0.5]", "v_max = [0.5, 0.5]\nconstriction = true", ["pso", "c1 + c2 > 4"]),
    ('obstacles = [{ shape = "circle", center = [10, 0], radius = 2 }]',
     'obstacles = [{ shape = "polygon", vertices = [[5, 5], [8, 5], [6, 9]] }]', ["scene.obstacles.0 is a polygon"]),
    ("position = [0, 0]", "position = [10, 0.5]", ["groups.0", "goal", "[10, 0.5] lies inside scene.obstacles.0"]),
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
    ("position = [33, 0]", "position = [20, 0.4]", ["goal: the point [20, 0.4] lies inside scene.obstacles.0"]),
    ("rows = 3, cols", "rows = 0, cols", ["groups.0.formation.block.rows", "got 0"]),
    ('kind = "block", rows = 3, cols = 3, spacing = 1.2', 'kind = "hexagon"', ["groups.0.formation", "hexagon"]),
    ("field_range = 1.5", "field_range = -1", ["formation.field_range", "got -1"]),
    ("field_range = 1.5", "relink_ratio = 3.0", ["relink_ratio 3.0 must not exceed tear_ratio"]),
    ("bounds = [[0, -10], [40, 10]]", "bounds = [[0, -10, 0], [40, 10, 5]]", ["not 3D like the scene"]),
    ("spacing = 1.2", "spacing = 0.4", ["overlap at the start"]),
])
def test_formation_scenario_errors_name_the_field(old, new, words):
    _refused(FORMATION.replace(old, new), words)


def test_a_group_attribute_written_in_the_group_table_says_to_write_it_under_attributes():
    # heading_deg = 0.0 beside count and radius said only "is not a known field"
    with pytest.raises(ScenarioError) as e:
        parse_scenario(FORMATION.replace("count = 9", "count = 9\nheading_deg = 0.0"))
    line = next(ln for ln in str(e.value).splitlines() if "groups.0.heading_deg" in ln)
    assert "group attribute (method 'formation' reads it)" in line
    assert "attributes = { heading_deg = ... }" in line and "(got 0.0)" in line
    with pytest.raises(ScenarioError, match=r"groups.0.reassign.*method 'formation' reads it.*attributes = \{ reassign"):
        parse_scenario(FORMATION.replace("count = 9", "count = 9\nreassign = false"))


@pytest.mark.parametrize("coordinates", ["bounds only", "all"])
def test_a_3d_scene_under_a_2d_only_method_is_told_first_that_the_method_is_2d(coordinates):
    # it was refused field by field ("spawn coordinates [5, 0] are not 3D like the scene",
    # then "Scene.obstacles[0] ... is 2D"), never saying formation works in 2D only
    text = FORMATION.replace("bounds = [[0, -10], [40, 10]]", "bounds = [[0, -10, 0], [40, 10, 5]]")
    if coordinates == "all":
        text = (text.replace("center = [20, 0.4]", "center = [20, 0.4, 2]").replace("[5, 0]", "[5, 0, 2]")
                .replace("[33, 0]", "[33, 0, 2]").replace('"circle"', '"sphere"'))
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text)
    first = str(e.value).splitlines()[1].strip()
    assert first.startswith("scene.bounds: method 'formation' works in 2D only, but the scene is 3D")
    assert "set method = 'mdp' or 'pso' for a 3D scene" in first


def test_remove_on_arrival_is_one_option_in_mdp_and_rvo_and_the_old_mdp_name_still_reads():
    from crowdmotion.mdp import MDPParams
    from crowdmotion.rvo import RVOParams

    assert "remove_on_arrival" in MDPParams.model_fields and "remove_on_arrival" in RVOParams.model_fields
    assert MDPParams(despawn=True) == MDPParams(remove_on_arrival=True)
    sc = parse_scenario(GOOD.replace("max_steps = 30", "max_steps = 30\nremove_on_arrival = true"))
    assert sc.params.remove_on_arrival is True


# strict scenarios: a value of the wrong kind, an unknown key or another method's field is
# refused, naming it, instead of being read as something else or ignored

FORMATION_POINTS = FORMATION.replace('formation = { kind = "block", rows = 3, cols = 3, spacing = 1.2 }\n',
                                     'formation = { kind = "block", rows = 3, cols = 3, spacing = 1.2 }\n'
                                     'attributes = { reassign = false }\n')


@pytest.mark.parametrize("text,old,new,words", [
    (GOOD, "count = 4", "count = true", ["groups.0.count (group 'g')", "whole number", "got true"]),
    (GOOD, "count = 4", "count = 4.0", ["groups.0.count", "whole number", "got 4.0"]),
    (GOOD, "count = 4", 'count = "4"', ["groups.0.count", "without quotes"]),
    (GOOD, "seed = 1", "seed = false", ["seed", "got false"]),
    (GOOD, "max_steps = 30", "max_steps = 30\nforbid_crossing = 1", ["mdp.forbid_crossing", "true or false", "got 1"]),
    (GOOD, "max_steps = 30", 'max_steps = 30\ntheta = true', ["mdp.theta", "must be a number", "got true"]),
    (FORMATION_POINTS, "reassign = false", 'reassign = "no"', ["groups.0.attributes.reassign", "true or false",
                                                                 "got 'no'"]),
])
def test_a_value_of_the_wrong_kind_is_refused_not_converted(text, old, new, words):
    assert old in text
    _refused(text.replace(old, new), words)


def test_count_true_is_refused_naming_groups_0_count():
    _refused(GOOD.replace("count = 4", "count = true"), ["groups.0.count", "got true"])


def test_reassign_no_is_refused_not_read_as_true():
    _refused(FORMATION_POINTS.replace("reassign = false", 'reassign = "no"'), ["groups.0.attributes.reassign"])
    sc = parse_scenario(FORMATION_POINTS)
    assert sc.groups[0].attributes["reassign"] is False


@pytest.mark.parametrize("attrs,words", [
    ("pref_speed_rang = [1.0, 1.2]", ["groups.0.attributes.pref_speed_rang", "did you mean 'pref_speed_range'?"]),
    ("samples = 1e8", ["groups.0.attributes.samples", "whole number"]),
    ("samples = 100000000", ["groups.0.attributes.samples", "must be at most 10000"]),
    ("max_neighbors = -1", ["groups.0.attributes.max_neighbors", "got -1"]),
    ("safety = nan", ["groups.0.attributes.safety", "got nan"]),
    ("pref_speed_range = [1.2, 1.0]", ["groups.0.attributes.pref_speed_range", "low 1.2 exceeds high 1"]),
    ("heading_deg = 90.0", ["groups.0.attributes.heading_deg", "method 'formation'"]),
    ('personality = "A+"', ["groups.0.attributes.personality", "write it in the [[groups]] table"]),
])
def test_rvo_attributes_are_checked_like_the_rvo_block(attrs, words):
    text = RVO.replace('personality = "A+"\n', f"attributes = {{ {attrs} }}\n")
    _refused(text, words)


def test_attributes_samples_within_the_rvo_bound_reach_the_agents():
    sc = parse_scenario(RVO.replace('personality = "A+"\n', "attributes = { samples = 200, safety = 2 }\n"))
    assert sc.groups[0].attributes == {"samples": 200, "safety": 2}


@pytest.mark.parametrize("text,old,new,words", [
    (PSO, "count = 12", "count = 12\nattributes = { pref_speed_range = [1.0, 1.2] }",
     ["groups.0.attributes.pref_speed_range", "not an attribute method 'pso' reads: it belongs to method 'rvo'"]),
    (PSO, "count = 12", 'count = 12\npersonality = "A+"', ["groups.0.personality", "only method 'rvo'", "'pso'"]),
    (PSO, "[pso]", "[rvo]\nsamples = 10\n[pso]", ["rvo: a [rvo] table, but method = 'pso'"]),
    (PSO, "iterations = 80", "iterations = 80\ntime_step = 0.1",
     ["pso.time_step", "is not a [pso] parameter: it belongs to [rvo] and [formation]"]),
    (PSO, "iterations = 80", "iterations = 80\niteration = 3", ["pso.iteration", "did you mean 'iterations'?"]),
    (RVO, "max_steps = 50", "max_steps = 50\n[mdp]\nmax_steps = 4", ["mdp: a [mdp] table, but method = 'rvo'"]),
    (RVO, 'personality = "A+"', 'formation = { kind = "line", count = 5 }', ["groups.0.formation", "only method"]),
    (FORMATION, "field_range = 1.5", "field_range = 1.5\nsamples = 5", ["formation.samples", "[rvo]"]),
])
def test_another_methods_field_is_refused_naming_the_method(text, old, new, words):
    assert old in text
    _refused(text.replace(old, new), words)


def test_formats_empty_is_refused():
    _refused(GOOD + '[output]\nformats = []\n', ["output.formats", "at least 1"])


@pytest.mark.parametrize("old,new,words", [
    ("max_steps = 50", "max_steps = 50\ntime_step = 1e6", ["rvo.time_step", "must be at most 10"]),
    ("max_steps = 50", "max_steps = 1000000", ["more than a day", "rvo.max_steps", "rvo.time_step"]),
])
def test_an_absurd_time_step_or_duration_is_refused(old, new, words):
    _refused(RVO.replace(old, new), words)


def test_a_model_check_names_its_field_without_pydantic_words():
    with pytest.raises(ScenarioError) as e:
        parse_scenario(GOOD.replace("position = [9, 9]", "position = [9, 9, 9]"), "s.toml")
    text = str(e.value)
    assert "  groups.0.goal (group 'g'): coordinates [9.0, 9.0, 9.0] are not 2D" in text
    assert "(top level)" not in text and "Value error" not in text


def test_heading_deg_north_is_refused_naming_the_attribute():
    _refused(FORMATION_POINTS.replace("reassign = false", 'heading_deg = "north"'),
             ["groups.0.attributes.heading_deg", "must be a number", "'north'"])


def test_deeply_nested_toml_is_refused_in_a_sentence():
    _refused("a = " + "[" * 5000 + "]" * 5000, ["nested too deeply"])


@pytest.mark.parametrize("old,new,words", [
    ("bounds = [[0, 0], [10, 10]]", "bounds = [[0, 0], [1e12, 1e12]]", ["scene.bounds.1.0", "1000000", "got 1e+12"]),
    ("radius = 1 }", "radius = 1e300 }", ["scene.obstacles.0.circle.radius", "1000000"]),
    ("count = 4", "count = 4\nmax_speed = 1e9", ["groups.0.max_speed", "1000"]),
])
def test_a_1e12_m_scene_is_refused_naming_the_field_not_left_to_overflow(old, new, words):
    _refused(GOOD.replace(old, new), words)


def test_a_goal_region_reaching_outside_the_bounds_is_refused_where_goal_points_are_sampled():
    _refused(RVO.replace('goal = { shape = "rect", lower = [25, 1], upper = [29, 9] }',
                         'goal = { shape = "rect", lower = [25, 1], upper = [35, 9] }'),
             ["group 'a' (groups.0) goal: rect [25, 1]-[35, 9] reaches outside scene.bounds [0, 0]-[30, 10]"])


def test_an_unknown_shape_is_named_with_the_shapes_that_field_takes():
    with pytest.raises(ScenarioError) as err:
        parse_scenario(GOOD.replace('spawn = { shape = "rect"', 'spawn = { shape = "ellipse"'))
    assert "groups.0.spawn (group 'g'): shape 'ellipse' is not one of 'point', 'points', 'rect', 'disc', 'ring'" \
        in str(err.value)  # not the goal-only shapes (moving, antipodal)
    with pytest.raises(ScenarioError, match="shape 'oval' is not one of .*'moving'"):
        parse_scenario(GOOD.replace('goal = { shape = "point"', 'goal = { shape = "oval"'))


LATTICE = """
name = "block"
method = "{method}"
[scene]
bounds = [[0, 0], [30, 4]]
[[groups]]
name = "block"
count = 60
spawn = {{ shape = "lattice", lower = [1, 0.5], upper = [8, 3.5] }}
goal = {goal}
{extra}
"""


def test_a_lattice_spawn_starts_an_rvo_crowd_as_a_dense_block():
    sc = parse_scenario(LATTICE.format(method="rvo", goal='{ shape = "rect", lower = [27, 1], upper = [29, 3] }',
                                       extra="[rvo]\nmax_steps = 40\nsmoothing = \"none\""))
    assert isinstance(sc.groups[0].spawn, cm.Lattice)
    r = run_scenario(sc, progress=False)
    start = r.trajectories.positions[0]
    assert start[:, 0].min() >= 1 and start[:, 0].max() <= 8 and start[:, 1].min() >= 0.5
    assert r.summary["agent_agent_overlaps"] == 0


@pytest.mark.parametrize("method, extra, message", [
    ("mdp", "", "a lattice places bodies in continuous space, but the MDP method starts each agent on a free grid"),
    ("formation", "", "a lattice spreads a crowd's agents over a rectangle, but a formation keeps its template"),
])
def test_methods_that_place_agents_otherwise_refuse_a_lattice_by_name(method, extra, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(LATTICE.format(method=method, goal='{ shape = "point", position = [28, 2] }', extra=extra))


def test_a_lattice_is_no_goal():
    text = LATTICE.format(method="rvo", goal='{ shape = "lattice", lower = [27, 1], upper = [29, 3] }', extra="")
    with pytest.raises(ScenarioError, match=r"groups.0.goal \(group 'block'\): a lattice is a spawn shape, not a goal"):
        parse_scenario(text)


def test_speeds_in_another_unit_and_a_wall_outside_the_scene_are_warned_of():
    # a researcher's speeds in cm/s (130 for 1.3 m/s) ran at 33 m/s without a word, and a
    # mistyped wall outside the bounds turned a bottleneck into an open room
    text = RVO.replace("bounds = [[0, 0], [30, 10]]", 'bounds = [[0, 0], [30, 10]]\nobstacles = [{ shape = "box", '
                       'lower = [300.0, 300.0], upper = [302.0, 304.0] }]', 1)
    text = text.replace("count = ", "pref_speed = 130\nmax_speed = 150\ncount = ", 1)
    with pytest.warns(UserWarning) as seen:
        parse_scenario(text, "street.toml")
    said = " ".join(str(w.message) for w in seen)
    assert "groups.0.pref_speed = 130 m/s: speeds are metres per second" in said
    assert "scene.obstacles.0" in said and "lies wholly outside the scene bounds" in said
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_scenario(RVO, "street.toml")  # nothing to say of a plain scene



def test_a_spawn_area_largely_inside_a_wall_is_warned_of():
    # a new user's crossing: one group's spawn rect ran 5 m into a corner block; its agents
    # were placed in the free half without a word
    text = RVO.replace("bounds = [[0, 0], [30, 10]]", 'bounds = [[0, 0], [30, 10]]\nobstacles = [{ shape = "box", '
                       'lower = [0.0, 0.0], upper = [6.0, 5.0] }]', 1)
    with pytest.warns(UserWarning, match=r"groups.0.spawn: (4[0-9]|5[0-9])% of its area lies inside obstacles"):
        parse_scenario(text, "street.toml")
    touching = text.replace("lower = [1, 1], upper = [5, 9]", "lower = [1, 5], upper = [5, 9]", 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_scenario(touching, "street.toml")  # only touching the block: nothing to say

def test_a_method_parameter_written_at_the_top_level_is_pointed_to_its_table():
    with pytest.raises(ScenarioError) as err:
        parse_scenario(RVO.replace('method = "rvo"', 'method = "rvo"\ntimestep = 0.1'), "street.toml")
    assert "timestep: is not a top-level field; did you mean 'time_step' in the [rvo]" in str(err.value)


@pytest.mark.parametrize("old,new,field,right,wrong", [
    # a JuPedSim user's "speed" in a group: the group's own speeds, not the scenario's seed
    ("count = 4", "count = 4\nspeed = 1.2", "groups.0.speed", "did you mean 'max_speed'?", "'seed'"),
    # a [scene] key: suggested from the scene's fields, never a group's count
    ("bounds = [[0, 0], [10, 10]]", 'bounds = [[0, 0], [10, 10]]\nunits = "m"', "scene.units", None, "'count'"),
    # a box has no centre: a circle's 'center' is no fix for it
    ('{ shape = "circle", center = [5, 5], radius = 1 }', '{ shape = "box", lower = [4, 4], upper = [6, 6], centre = [5, 5] }',
     "scene.obstacles.0.box.centre", None, "'center'"),
    ("count = 4", "count = 4\nradus = 0.3", "groups.0.radus", "did you mean 'radius'?", None),
    ('position = [9, 9]', 'positon = [9, 9]', "groups.0.goal.point.positon", "did you mean 'position'?", None),
])
def test_an_unknown_field_is_matched_against_its_own_tables_fields(old, new, field, right, wrong):
    assert old in GOOD
    with pytest.raises(ScenarioError) as e:
        parse_scenario(GOOD.replace(old, new))
    line = next(ln for ln in str(e.value).splitlines() if field in ln)
    assert "is not a known field" in line
    if right:
        assert right in line
    if wrong:
        assert wrong not in line
