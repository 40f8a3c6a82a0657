"""A formation run's files: trajectories, summary and its pictures."""

from crowdmotion.outputs import write_run
from crowdmotion.scenario import parse_scenario, run_scenario
from tests.test_scenario import FORMATION


def test_a_run_writes_paths_field_snapshots_and_animation(tmp_path):
    result = run_scenario(parse_scenario(FORMATION), progress=False)
    names = {p.name for p in write_run(result, tmp_path)}
    assert {"trajectories.parquet", "summary.json", "paths.png", "field.png", "snapshots.png",
            "formation.gif"} <= names
    assert all((tmp_path / n).stat().st_size > 1000 for n in names)


def test_the_snapshots_figure_and_its_animation_drawn_apart_are_the_same_files(tmp_path):
    from crowdmotion.formation.adapter import PICTURE_PARTS, write_plots

    result = run_scenario(parse_scenario(FORMATION), progress=False)
    scene, run = result.scenario.scene, result.extras
    together, apart = tmp_path / "together", tmp_path / "apart"
    together.mkdir()
    apart.mkdir()
    both = write_plots(scene, run, together, ["snapshots"], "t")
    drawn = [p for part in PICTURE_PARTS["snapshots"] for p in write_plots(scene, run, apart, [part], "t")]
    assert [p.name for p in both] == [p.name for p in drawn] == ["snapshots.png", "formation.gif"]
    for p in both:
        assert p.read_bytes() == (apart / p.name).read_bytes()


def test_a_formation_goal_outside_the_bounds_is_refused_not_run_to_zero_recovered():
    from tests.test_scenario import _refused

    _refused(FORMATION.replace("position = [33, 0]", "position = [60, 0]"),
             ["group 'squad' (groups.0) goal: the point [60, 0] lies outside scene.bounds [0, -10]-[40, 10]"])
    _refused(FORMATION.replace('goal = { shape = "point", position = [33, 0] }',
                               'goal = { shape = "rect", lower = [50, -2], upper = [55, 2] }'),
             ["group 'squad' (groups.0) goal: rect [50, -2]-[55, 2] lies outside scene.bounds"])
