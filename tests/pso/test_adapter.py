"""What a particle-swarm scenario is refused for before it runs, as RVO's and MDP's are:
goals outside the bounds, starts in obstacles or on top of each other, walls across the
way, generated obstacle fields that leave no room to start."""


import pytest

from crowdmotion.scenario import ScenarioError, parse_scenario

SCENE = """
method = "pso"
[scene]
bounds = [[0, 0], [30, 20]]
obstacles = [{{ shape = "box", lower = [20, 5], upper = [25, 15] }}{more}]
[[groups]]
name = "w"
count = {count}
spawn = {spawn}
goal = {goal}
[pso]
v_max = [0.1]
{extra}
"""
RECT = '{ shape = "rect", lower = [2, 5], upper = [8, 15] }'
POINT = '{ shape = "point", position = [28, 10] }'


def scenario(count=9, spawn=RECT, goal=POINT, more="", extra=""):
    return SCENE.format(count=count, spawn=spawn, goal=goal, more=more, extra=extra)


def refused(text, *words):
    with pytest.raises(ScenarioError) as e:
        parse_scenario(text, "s.toml")
    for w in words:
        assert w in str(e.value), str(e.value)


def test_the_scene_used_here_is_accepted():
    assert parse_scenario(scenario()).groups[0].count == 9


@pytest.mark.parametrize("goal,words", [
    ('{ shape = "point", position = [50, 10] }', ["goal: the point [50, 10] lies outside scene.bounds"]),
    ('{ shape = "rect", lower = [40, 5], upper = [45, 8] }', ["goal: rect [40, 5]-[45, 8] lies outside scene.bounds"]),
    ('{ shape = "moving", times = [0, 10], positions = [[5, 5], [50, 5]] }',
     ["moving target's keyframe 1 at [50, 5] lies outside scene.bounds"]),
])
def test_a_pso_goal_outside_the_bounds_is_refused(goal, words):
    refused(scenario(goal=goal), "group 'w' (groups.0)", *words)


def test_a_pso_start_inside_an_obstacle_is_refused_naming_the_obstacle():
    refused(scenario(count=2, spawn='{ shape = "points", points = [[3, 3], [22, 10]] }'),
            "spawn: the point [22, 10] lies inside scene.obstacles.0 (box [20, 5]-[25, 15])")


def test_a_pso_start_outside_the_bounds_is_refused():
    refused(scenario(count=2, spawn='{ shape = "points", points = [[3, 3], [-5, 10]] }'),
            "spawn: the point [-5, 10] lies outside scene.bounds")


def test_duplicate_pso_starts_are_refused_not_run_into_overlaps():
    refused(scenario(count=3, spawn='{ shape = "points", points = [[3, 3], [6, 6], [3, 3]] }'),
            "start points 0 [3, 3] and 2 [3, 3] are 0 m apart", "would overlap at the start")


def test_duplicate_starts_are_allowed_when_particles_ignore_each_other():
    text = scenario(count=2, spawn='{ shape = "points", points = [[3, 3], [3, 3]] }').replace(
        "v_max = [0.1]", "v_max = [0.1]\navoid_agents = false")
    assert parse_scenario(text).groups[0].count == 2


def test_a_wall_across_a_pso_scene_is_refused_as_an_unreachable_goal():
    refused(scenario(more=', { shape = "box", lower = [14, 0], upper = [15, 20] }'),
            "goal: point [28, 10] cannot be reached from the spawn rect [2, 5]-[8, 15]",
            "radius 0.25 m")


def test_a_wall_with_a_door_wide_enough_is_accepted():
    doorway = (', { shape = "box", lower = [14, 0], upper = [15, 9.5] }, '
               '{ shape = "box", lower = [14, 10.2], upper = [15, 20] }')  # a 0.7 m door, 0.5 m bodies
    assert parse_scenario(scenario(more=doorway)).scene.dim == 2


def test_a_pso_obstacle_field_that_leaves_no_room_to_start_is_refused_at_once(monkeypatch):
    import crowdmotion.pso.simulation as pso_simulation
    from crowdmotion.pso.adapter import FIELD_DRAWS

    draws = []
    real = pso_simulation.generated_obstacles
    monkeypatch.setattr(pso_simulation, "generated_obstacles", lambda *a, **kw: draws.append(1) or real(*a, **kw))
    refused(scenario(extra="[pso.obstacle_field]\ncount = 5000\nradius = 2"),
            "pso.obstacle_field: 5000 obstacles of radius 2 m leave group 'w' (groups.0) room for at most 0 agents",
            "count = 9")
    assert len(draws) == FIELD_DRAWS, "refused after the check's own draws, before any run or placement"
    assert parse_scenario(scenario(extra="[pso.obstacle_field]\ncount = 5\nradius = 1")).params.obstacle_field


def test_a_3d_wall_across_the_scene_is_refused_too():
    text = """
method = "pso"
[scene]
bounds = [[0, 0, 0], [20, 20, 20]]
obstacles = [{ shape = "box", lower = [9, 0, 0], upper = [10, 20, 20] }]
[[groups]]
name = "drones"
count = 5
spawn = { shape = "rect", lower = [1, 1, 1], upper = [5, 5, 5] }
goal = { shape = "point", position = [15, 15, 15] }
"""
    refused(text, "group 'drones' (groups.0) goal", "cannot be reached")


def test_a_moving_target_led_through_an_obstacle_between_its_keyframes_is_refused_naming_the_time():
    # both keyframes stand clear; the swarm reads the target every 100 iterations of 0.25 s,
    # and at 25 s it lies inside the box
    refused(scenario(goal='{ shape = "moving", times = [0, 40], positions = [[10, 10], [28, 10]] }'),
            "group 'w' (groups.0) goal: the moving target passes through an obstacle: at t = 25 s "
            "(between its keyframes at 0 and 40 s", "it is at [21.25, 10.0]")
