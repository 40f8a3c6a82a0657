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


OBSTACLES = [[{"shape": "box", "lower": [4, 0], "upper": [5, 3.4]},
              {"shape": "circle", "center": [7, 7], "radius": 0.5},
              {"shape": "box", "lower": [1, 6], "upper": [2.5, 8]},
              {"shape": "circle", "center": [3, 4.5], "radius": 0.4}],
             [{"shape": "circle", "center": [5, 5], "radius": 1}]]


def test_run_file_names_are_short_safe_and_the_same_for_the_same_sweep(tmp_path):
    from crowdmotion.sweep import MAX_STEM, run_names

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    runs = plan(path, [0, 1], {"scene.obstacles": OBSTACLES, "mdp.tau": [0.5, 1]})
    names = run_names(runs)
    assert len(set(names)) == 8 and names == run_names(plan(path, [0, 1], {"scene.obstacles": OBSTACLES,
                                                                           "mdp.tau": [0.5, 1]}))
    for name in names:  # a list of tables as a digest of it: no braces, quotes, spaces or slashes
        assert len(name) <= MAX_STEM and all(c.isalnum() or c in "._+-=@" for c in name), name
    first = names[0].split("_")
    assert first[0] == "seed0" and first[1].startswith("scene.obstacles=@") and first[2] == "mdp.tau=0.5"
    # plain values keep their readable names (a sweep folder of before reads as it did)
    assert run_names([({}, 3, {"mdp.tau": 0.5, "groups.0.personality": "O+"})]) == \
        ["seed3_mdp.tau=0.5_groups.0.personality=O+"]
    # values whose plain names would meet (on a system blind to case too) are told apart by digests
    for values in (["O+", "o+"], [1, "1"], [True, "True"]):
        named = run_names([({}, 0, {"x": v}) for v in values])
        assert len({n.casefold() for n in named}) == 2 and all("=@" in n for n in named), named
    texts = run_names([({}, 0, {"x": v}) for v in ("a b", "a/b", "x" * 300)])
    assert all(len(n) < 30 and "=@" in n for n in texts), texts
    many = {f"groups.{i}.spawn.upper": [4.25, 3.75] for i in range(12)}  # readable parts, too long together
    assert run_names([({}, 0, many)])[0].startswith("seed0_settings=@")


def test_a_sweep_over_obstacle_lists_writes_short_names_and_the_table_keeps_the_full_values(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    table = sweep(path, seeds=[0], settings={"scene.obstacles": OBSTACLES}, out=tmp_path / "out", workers=1,
                  processes=False, progress=False)
    import json

    assert [json.loads(v) for v in table["scene.obstacles"].to_pylist()] == OBSTACLES
    files = sorted(p.name for p in (tmp_path / "out" / "runs").iterdir())
    assert files == sorted(f"{n}.parquet" for n in (row.split("/")[-1][:-8] for row in table["file"].to_pylist()))
    assert all(len(f) < 60 for f in files), files


def test_a_combination_the_method_refuses_is_named(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    with pytest.raises(ScenarioError, match=r"^sweep groups.0.count = 60: group 'g' spawn: .* count = 60 agents"):
        plan(path, [0], {"groups.0.count": [4, 60]})


def test_a_run_that_fails_is_named_and_the_runs_finished_are_kept(tmp_path, monkeypatch):
    import crowdmotion.sweep as sw

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    simulate = sw._simulate

    def fail_seed_1(data, seed, setting, file, label):
        if seed == 1:
            raise OSError(36, "File name too long")
        return simulate(data, seed, setting, file, label)

    monkeypatch.setattr(sw, "_simulate", fail_seed_1)
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=r"^sweep mdp.tau = 0.5, seed 1: \[Errno 36\] File name too long; the 1 "
                                         r"runs finished are kept .*--resume"):
        sweep(path, seeds=[0, 1], settings={"mdp.tau": [0.5]}, out=out, workers=1, processes=False, progress=False)
    table = pq.read_table(out / "sweep.parquet")
    assert table["seed"].to_pylist() == [0]
    assert sw.sweep_record(table) | {"keys": None} == {"planned": 2, "partial": True, "stopped_by": "error",
                                                        "keys": None}


def test_resume_keeps_the_runs_finished_and_refuses_another_scenario_or_settings(tmp_path, monkeypatch):
    import crowdmotion.sweep as sw

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "out"
    sweep(path, seeds=[0, 1], out=out, workers=1, processes=False, progress=False)
    before = {f.name: f.stat().st_mtime_ns for f in (out / "runs").iterdir()}
    simulated = []
    simulate = sw._simulate
    monkeypatch.setattr(sw, "_simulate",
                        lambda data, seed, *rest: simulated.append(seed) or simulate(data, seed, *rest))
    table = sweep(path, seeds=[0, 1, 2], out=out, workers=1, processes=False, progress=False, resume=True)
    assert simulated == [2] and table["seed"].to_pylist() == [0, 1, 2]  # seeds 0 and 1 read back
    assert {f: (out / "runs" / f).stat().st_mtime_ns for f in before} == before
    assert not sw.sweep_record(table)["partial"]
    with pytest.raises(ValueError, match="holds run seed0.parquet .*, which this sweep does not plan"):
        sweep(path, seeds=[0], settings={"mdp.tau": [0.5]}, out=out, processes=False, progress=False, resume=True)
    path.write_text(GOOD.replace("max_steps = 30", "max_steps = 20"))
    with pytest.raises(ValueError, match="run seed0.parquet was made from another scenario"):
        sweep(path, seeds=[0, 1, 2], out=out, processes=False, progress=False, resume=True)
    pq.write_table(pq.read_table(out / "sweep.parquet").replace_schema_metadata(None), out / "sweep.parquet")
    with pytest.raises(ValueError, match="written by an earlier crowdmotion.*--overwrite"):
        sweep(path, seeds=[0, 1, 2], out=out, processes=False, progress=False, resume=True)
    assert simulated == [2]


class _StopAfter:
    """A progress bar that presses Ctrl-C once ``runs`` runs have finished."""

    def __init__(self, runs: int):
        self.runs, self.done = runs, 0

    def __call__(self, *args, **kwargs):
        import contextlib

        @contextlib.contextmanager
        def bar():
            yield self

        return bar()

    def update(self, n: int) -> None:
        self.done += n
        if self.done >= self.runs:
            raise KeyboardInterrupt


def test_an_interrupted_sweep_keeps_its_runs_reports_them_and_resumes(tmp_path, monkeypatch, capsys):
    import json

    import crowdmotion.sweep as sw

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "sw"
    command = ["sweep", str(path), "--seeds", "0:6", "--workers", "1", "-o", str(out), "-q"]
    with monkeypatch.context() as m:
        m.setattr(sw, "counter", _StopAfter(1))
        assert main(command) == 130
    err = capsys.readouterr().err
    table = pq.read_table(out / "sweep.parquet")
    record = sw.sweep_record(table)
    assert record["partial"] and record["stopped_by"] == "interrupt" and 1 <= table.num_rows < 6
    assert f"{table.num_rows} of 6 runs finished; {out / 'sweep.parquet'} lists them (partial)" in err, err
    assert "Traceback" not in err and "distributed" not in err, err
    assert sorted(f.name for f in (out / "runs").iterdir()) == sorted(  # no other file: none half written
        f.split("/")[-1] for f in table["file"].to_pylist())
    assert main(["report", str(out)]) == 0
    assert f"the sweep was interrupted: {table.num_rows} of 6 planned runs finished" in capsys.readouterr().out
    assert json.loads((out / "report.json").read_text())["partial"] is True
    assert main(command) == 2 and "--resume to finish it" in capsys.readouterr().err
    kept = {f.name: f.stat().st_mtime_ns for f in (out / "runs").iterdir()}
    assert main(command + ["--resume"]) == 0
    whole = pq.read_table(out / "sweep.parquet")
    assert whole["seed"].to_pylist() == list(range(6)) and not sw.sweep_record(whole)["partial"]
    assert {f: (out / "runs" / f).stat().st_mtime_ns for f in kept} == kept  # read back, not run again
    assert whole.slice(0, table.num_rows).drop(["file"]).equals(table.drop(["file"]))


def test_a_sweep_at_the_top_of_a_script_without_the_main_guard_is_refused_saying_so(tmp_path):
    import subprocess
    import sys

    from crowdmotion.sweep import _under_main_guard

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    script = tmp_path / "study.py"
    script.write_text(f"from crowdmotion.sweep import sweep\n\n"
                      f"sweep({str(path)!r}, seeds=[0], out={str(tmp_path / 'o')!r})\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and 'put the sweep under `if __name__ == "__main__":`' in done.stderr, done.stderr
    assert "Nanny" not in done.stderr and not (tmp_path / "o").exists()
    guarded = 'import x\n\n\ndef main():\n    x.sweep()\n\n\nif __name__ == "__main__":\n    main()\n    print(1)\n'
    assert [_under_main_guard(guarded, line) for line in (1, 5, 9, 10)] == [False, False, True, True]
    assert _under_main_guard("if '__main__' == __name__:\n    go()\n", 2) is True
    assert _under_main_guard("def (:\n", 1) is None
