"""Sweeps on Dask: one file and one summary row per run; bad settings refused first."""

import pyarrow.parquet as pq
import pytest

from crowdmotion.cli import main
from crowdmotion.scenario import ScenarioError
from crowdmotion.sweep import plan, sweep
from tests.test_scenario import GOOD


def test_eight_seeds_on_a_local_cluster_give_eight_rows_and_eight_files(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    table = sweep(path, seeds=range(8), out=tmp_path / "out", workers=2, processes=False, progress=False)
    assert table.num_rows == 8 and sorted(table["seed"].to_pylist()) == list(range(8))
    files = sorted((tmp_path / "out" / "runs").glob("*.parquet"))
    assert len(files) == 8
    assert pq.read_table(tmp_path / "out" / "sweep.parquet").num_rows == 8
    assert set(table["agent_agent_overlaps"].to_pylist()) == {0.0}


def test_settings_multiply_the_runs_and_bad_values_name_the_field(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    runs = plan(path, [0, 1], {"mdp.tau": [0.5, 2.0], "mdp.theta": [1.0]})
    assert len(runs) == 4 and {r[2]["mdp.tau"] for r in runs} == {0.5, 2.0}
    with pytest.raises(ScenarioError, match="mdp.tau"):
        plan(path, [0], {"mdp.tau": [-1.0]})
    with pytest.raises(ValueError, match="non-negative"):
        plan(path, [-1], None)


def _tau_sweep(tmp_path, out, workers: int):
    """The command on GOOD: seeds 0 and 1 x mdp.tau 0.5 and 1.0 into ``out``; its scenario file."""
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    assert main(["sweep", str(path), "--seeds", "0:2", "--set", "mdp.tau=0.5,1.0", "--workers", str(workers), "-o",
                 str(out), "-q"]) == 0
    return path


def test_sweep_command(tmp_path, capsys):
    out = tmp_path / "cli"
    path = _tau_sweep(tmp_path, out, workers=2)
    assert "4 runs" in capsys.readouterr().out
    table = pq.read_table(out / "sweep.parquet")
    assert table.num_rows == 4 and sorted(set(table["mdp.tau"].to_pylist())) == [0.5, 1.0]  # numbers, not text
    for bad in ("a:b", "-1:2"):  # -1:2 is a seed range, not an option: told what is wrong with it
        with pytest.raises(SystemExit) as exc:
            main(["sweep", str(path), "--seeds", bad])
        assert exc.value.code == 2 and f"--seeds must look like 0:100, 1,4,9 or 7 (whole numbers of at least 0), " \
            f"got '{bad}'" in capsys.readouterr().err


def test_sweep_set_seed_is_refused_pointing_to_seeds(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    with pytest.raises(SystemExit) as exc:
        main(["sweep", str(path), "--set", "seed=1,2", "-o", str(tmp_path / "o")])
    assert exc.value.code == 2 and "--seeds" in capsys.readouterr().err
    with pytest.raises(ValueError, match="seed cannot be a setting"):
        plan(path, [0], {"seed": [1, 2]})
    assert not (tmp_path / "o").exists()


def test_sweep_set_given_twice_for_one_field_is_refused(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    assert main(["sweep", str(path), "--set", "mdp.tau=0.5", "--set", "mdp.tau=2", "-o", str(tmp_path / "o")]) == 2
    assert "--set mdp.tau is given twice" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_sweep_setting_another_methods_field_is_refused_naming_it(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    with pytest.raises(ScenarioError, match=r"rvo: a \[rvo\] table, but method = 'mdp'"):
        plan(path, [0], {"rvo.samples": [5]})


def test_a_sweep_report_gives_each_setting_its_own_intervals_and_a_second_sweep_is_not_written_over(tmp_path, capsys):
    import json

    out = tmp_path / "sw"
    path = _tau_sweep(tmp_path, out, workers=1)
    capsys.readouterr()
    assert main(["report", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "mdp.tau = 0.5:\n2 runs;" in printed and "mdp.tau = 1:\n2 runs;" in printed, printed
    report = json.loads((out / "report.json").read_text())
    assert report["settings"] == ["mdp.tau"] and [p["setting"] for p in report["by_setting"]] == \
        [{"mdp.tau": 0.5}, {"mdp.tau": 1.0}] and [p["runs"] for p in report["by_setting"]] == [2, 2]
    assert "groups" not in report, "no interval pooled over the settings"
    assert sorted(k["seed"] for k in report["run_keys"]) == [0, 0, 1, 1]
    # the same folder again: refused, then replaced with --overwrite
    assert main(["sweep", str(path), "--seeds", "0:1", "-o", str(out), "-q"]) == 2
    assert "holds an earlier sweep (sweep.parquet, 4 runs in runs/)" in capsys.readouterr().err
    assert main(["sweep", str(path), "--seeds", "0:1", "--workers", "1", "-o", str(out), "-q", "--overwrite"]) == 0
    assert len(list((out / "runs").glob("*.parquet"))) == 1 and not (out / "report.json").exists()
    assert main(["report", str(out / "runs")]) == 2
    assert f"it holds a sweep's runs; give the sweep's folder ({out})" in capsys.readouterr().err
    assert pq.read_table(out / "sweep.parquet").num_rows == 1


@pytest.mark.parametrize("name,message", [
    ("groups.5.count", "groups has 1 entry (0 to 0), no 5"),
    ("groups.x.count", "groups is a list: groups.x needs a whole number (0 for its first entry), not 'x'"),
    ("groups.0.count.x", "groups.0.count is a value (4), not a table with fields"),
    ("scene.obstacles.3.radius", "scene.obstacles has 1 entry (0 to 0), no 3"),
])
def test_a_sweep_setting_that_leads_nowhere_is_refused_naming_it(tmp_path, name, message):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    with pytest.raises(ValueError, match=f"sweep setting {name}: " + message.replace("(", r"\(").replace(")", r"\)")):
        plan(path, [0], {name: [3]})
    path.write_text(GOOD.replace('obstacles = [{ shape = "circle", center = [5, 5], radius = 1 }]', ""))
    with pytest.raises(ValueError, match="the scenario gives no scene.obstacles to set entry 0 of"):
        plan(path, [0], {"scene.obstacles.0.radius": [3]})


def test_sweep_set_reads_arrays_and_bare_words_as_values():
    from crowdmotion.cli import _setting

    assert _setting("groups.0.spawn.upper=[4.3, 3.7],[5, 6]") == ("groups.0.spawn.upper", [[4.3, 3.7], [5, 6]])
    assert _setting("rvo.safety=1,3,7.5") == ("rvo.safety", [1, 3, 7.5])
    assert _setting("groups.0.personality=O+, O-") == ("groups.0.personality", ["O+", "O-"])
    assert _setting('groups.0.name="a,b",c') == ("groups.0.name", ["a,b", "c"])


def test_a_sweep_table_keeps_counts_whole_and_the_settings_in_the_order_given(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    table = sweep(path, seeds=[0], settings={"groups.0.count": [4, 2]}, out=tmp_path / "out", workers=1,
                  processes=False, progress=False)
    assert table["groups.0.count"].to_pylist() == [4, 2]  # as given, not as text ("4" after "2")
    for column in ("groups.0.count", "agents", "frames", "agent_agent_overlaps"):
        assert str(table.schema.field(column).type) == "int64", column
