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
