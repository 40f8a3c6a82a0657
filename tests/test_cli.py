"""The crowdmotion command, as a user runs it."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from crowdmotion.cli import main
from tests.test_scenario import GOOD


def test_validate_run_and_errors(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    assert main(["validate", str(path)]) == 0
    assert "OK" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "--seed", "4", "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["seed"] == 4 and summary["agent_agent_overlaps"] == 0
    assert (out / "trajectories.parquet").is_file() and (out / "paths.png").is_file()
    bad = tmp_path / "bad.toml"
    bad.write_text(GOOD.replace("count = 4", "count = 0"))
    assert main(["validate", str(bad)]) == 2
    assert "groups.0.count" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "missing.toml")]) == 2


def test_render_keeps_the_run_s_own_paths_picture_and_draws_one_where_it_has_none(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    drawn, bare = tmp_path / "drawn", tmp_path / "bare"
    assert main(["run", str(path), "-o", str(drawn), "-q"]) == 0
    assert main(["run", str(path), "-o", str(bare), "-q", "--plots", "none"]) == 0
    own = (drawn / "paths.png").read_bytes()  # with the run's goals and its scenario's name
    capsys.readouterr()
    for folder in (drawn, bare):
        assert main(["render", str(folder), "--to", "gif", "--max-frames", "2", "-q"]) == 0
    said = capsys.readouterr().out  # two frames for the whole run: it plays faster, and says so
    assert re.search(r"animation\.gif \(\d+ s shown in 0 s: [\d.]+x real time; --max-frames \d+ plays it at its own", said)
    assert (drawn / "paths.png").read_bytes() == own
    assert (bare / "paths.png").stat().st_size > 5_000 and (bare / "density.png").is_file()
    assert "paths.png" in json.loads((bare / "manifest.json").read_text())["files"]


def test_run_plots_option_replaces_the_scenarios_pictures(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    bare, player = tmp_path / "bare", tmp_path / "player"
    assert main(["run", str(path), "-o", str(bare), "-q", "--plots", "none"]) == 0
    assert {p.name for p in bare.iterdir()} == {"trajectories.parquet", "summary.json", "manifest.json"}
    assert main(["run", str(path), "-o", str(player), "-q", "--plots", "player"]) == 0
    assert (player / "view.html").is_file() and not (player / "paths.png").exists()
    capsys.readouterr()
    for wrong, words in (("paht", "'paht' is not one of paths"), ("", "names no picture"), (",", "names no picture")):
        with pytest.raises(SystemExit) as exc:
            main(["run", str(path), "-o", str(tmp_path / "x"), "--plots", wrong])
        assert exc.value.code == 2
        assert words in capsys.readouterr().err
        assert not (tmp_path / "x").exists()


def test_demo_writes_pictures(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path), "--only", "mdp_drones_3d", "-q"]) == 0
    assert (tmp_path / "mdp_drones_3d" / "paths.png").stat().st_size > 10_000
    assert (tmp_path / "mdp_drones_3d" / "values.png").is_file()
    assert (tmp_path / "mdp_drones_3d" / "view.html").stat().st_size > 10_000  # the player
    assert str(tmp_path) in capsys.readouterr().out


def test_rvo_run_then_report(tmp_path, capsys):
    from tests.test_scenario import RVO

    path = tmp_path / "street.toml"
    path.write_text(RVO.replace("max_steps = 50", "max_steps = 400"))
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "rvo" and set(summary["groups"]) == {"a", "ring"}
    assert summary["agent_agent_overlaps"] == 0 and summary["arrival_rate"] == 1.0
    capsys.readouterr()
    assert main(["report", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "ring" in printed and "mixing" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["a"]["agents"] == 5
    assert main(["report", str(tmp_path / "nowhere")]) == 2


def test_export_to_every_format_and_bad_requests(tmp_path, capsys):
    import numpy as np

    from crowdmotion import Trajectories

    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace("[mdp]", '[mdp]\nsmoothing = "none"'))  # a run at its own step rate
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0
    original = Trajectories.load(out / "trajectories.parquet")
    for fmt, name in [("sqlite", "trajectories.sqlite"), ("usd", "trajectories.usdc"), ("usda", "trajectories.usda"),
                      ("csv", "trajectories.csv")]:
        assert main(["export", str(out), "--to", fmt]) == 0, fmt
        back = Trajectories.load(out / name)
        if fmt.startswith("usd"):  # a DCC plays 24 fps: the B-spline of the run's frames
            assert back.fps == 24.0 and original.fps < 24.0
            at_frames = np.round(original.times * 24).astype(int)
            off = np.linalg.norm(back.positions[at_frames] - original.positions, axis=-1)
            # the spline passes a sixth of the second difference from a run's frame; the
            # nearest 24 fps frame is up to 1/48 s away from it
            P = original.positions
            bend = np.linalg.norm(P[:-2] - 2 * P[1:-1] + P[2:], axis=-1) / 6
            fastest = np.linalg.norm(np.diff(P, axis=0), axis=-1).max() / original.dt
            assert (off[1:-1] <= bend + fastest / 48).all() and off.max() > 0
            np.testing.assert_allclose(back.positions[0], original.positions[0], atol=1e-5)  # starts where it starts
            continue
        np.testing.assert_allclose(back.positions, original.positions, atol=1e-5)
        assert back.dt == original.dt or abs(back.dt - original.dt) < 1e-12
    assert "wrote" in capsys.readouterr().out
    # asked for: the run's own frames in USD too, or straight moves at 24 fps
    assert main(["export", str(out), "--to", "usda", "--fps", str(original.fps), "-o", str(tmp_path / "own.usda")]) == 0
    np.testing.assert_allclose(Trajectories.load(tmp_path / "own.usda").positions, original.positions, atol=1e-5)
    assert main(["export", str(out), "--to", "csv", "--fps", "24", "--interpolation", "linear",
                 "-o", str(tmp_path / "lin.csv")]) == 0
    lin = Trajectories.load(tmp_path / "lin.csv")
    want = np.stack([[np.interp(lin.times, original.times, original.positions[:, i, k]) for k in range(2)]
                     for i in range(original.n_agents)]).transpose(2, 0, 1)  # on the straight moves
    np.testing.assert_allclose(lin.positions, want, atol=1e-5)
    assert main(["export", str(tmp_path / "nowhere"), "--to", "usd"]) == 2
    assert "no run folder" in capsys.readouterr().err
    (tmp_path / "broken.parquet").write_bytes(b"garbage")
    assert main(["export", str(tmp_path / "broken.parquet"), "--to", "sqlite"]) == 2
    assert "not a readable Parquet" in capsys.readouterr().err
    assert main(["export", str(out), "--to", "sqlite", "-o", str(tmp_path / "no" / "such" / "dir.sqlite")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_bench_reaches_every_methods_benchmark(capsys):
    # peers (pyrvo, JuPedSim) come with the [bench] extra; without them their columns are empty
    assert main(["bench", "formation", "--sizes", "200", "--steps", "2"]) == 0
    assert "| agents | mesh generation |" in capsys.readouterr().out
    assert main(["bench", "rvo", "--sizes", "200", "--steps", "2", "--stand", "60", "--jupedsim-max", "0"]) == 0
    out = capsys.readouterr().out
    assert "| circle | 200 |" in out and "| 60 | crowdmotion.rvo |" in out
    # mdp's own options after the method's name, as for the others (they were refused)
    assert main(["bench", "mdp", "--no-reference", "--repeats", "1", "-q"]) == 0
    out = capsys.readouterr().out
    assert "| 50x20x50 |" in out and "ref Dijkstra, unsorted" in out


def test_every_argument_has_help_text():
    import argparse

    from crowdmotion.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"{name} {a.dest}" for name, p in sub.choices.items() for a in p._actions
               if not a.help and not isinstance(a, argparse._HelpAction)]
    assert not missing, missing
    assert all(c.help for c in sub._choices_actions), "every subcommand has a one-line help"


def test_python_dash_m_runs_the_command():
    import subprocess
    import sys

    from crowdmotion import __version__

    done = subprocess.run([sys.executable, "-m", "crowdmotion", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and __version__ in done.stdout
    done = subprocess.run([sys.executable, "-m", "crowdmotion", "validate", "no-such-scene.toml"], capture_output=True,
                          text=True)
    assert done.returncode == 2 and "no-such-scene.toml" in done.stderr


def test_scenarios_lists_every_builtin_with_its_description(capsys):
    from crowdmotion.cli import builtin_scenarios

    assert main(["scenarios"]) == 0
    printed = capsys.readouterr().out
    for path in builtin_scenarios():
        assert path.stem in printed and str(path) in printed
    assert "army block marches through scattered rocks" in printed


def _named(tmp_path, name: str):
    """A scenario file whose ``name = <name>`` is written as a TOML basic string."""
    path = tmp_path / "named.toml"
    path.write_text(GOOD.replace('name = "t"', f"name = {json.dumps(name)}"))
    return path


def test_a_scenario_named_dot_dot_x_is_refused_at_validate_naming_the_field(tmp_path, capsys, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    path = _named(tmp_path, "../../x")
    for command in ("validate", "run"):
        assert main([command, str(path), "-q"] if command == "run" else [command, str(path)]) == 2
        err = capsys.readouterr().err
        assert str(path) in err and "name:" in err and "'../../x'" in err and "path separator" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["named.toml", "work"] and not any(work.iterdir())


@pytest.mark.parametrize("name", ["/tmp/elsewhere", "..", ".", "", "a\\b", "x" * 101])
def test_an_absolute_name_is_refused(tmp_path, capsys, name):
    assert main(["validate", str(_named(tmp_path, name))]) == 2
    err = capsys.readouterr().err
    assert "name:" in err and repr(name)[:60] in err, err


@pytest.mark.parametrize("name", ["red\x1b[31mtext", "nul\x00byte", "tab\there"])
def test_a_name_with_a_terminal_escape_is_refused_and_the_message_shows_it_escaped(tmp_path, capsys, name):
    assert main(["validate", str(_named(tmp_path, name))]) == 2
    captured = capsys.readouterr()
    assert repr(name) in captured.err and "control" in captured.err, captured.err
    assert not any(c in captured.err + captured.out for c in "\x1b\x00\t"), "no raw control character printed"


def test_the_default_output_folder_of_a_valid_name_lies_inside_out(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = _named(tmp_path, "street run é")
    assert main(["validate", str(path)]) == 0
    assert f"output folder {Path('out') / 'street run é'}" in capsys.readouterr().out
    assert main(["run", str(path), "-q", "--plots", "none"]) == 0
    written = tmp_path / "out" / "street run é" / "summary.json"
    assert written.is_file() and written.resolve().parent.parent == (tmp_path / "out").resolve()


# 40 walkers at 2 cm/s down a 200 m street: minutes of steps, for a run the test stops
LONG = """
name = "long"
method = "rvo"
[scene]
bounds = [[0, 0], [200, 20]]
[[groups]]
name = "a"
count = 40
pref_speed = 0.02
max_speed = 0.05
spawn = { shape = "rect", lower = [1, 1], upper = [15, 19] }
goal = { shape = "rect", lower = [190, 1], upper = [199, 19] }
[rvo]
max_steps = 300000
[output]
plots = []
"""


def start_long_run(tmp_path, out):
    """``crowdmotion run`` of LONG into ``out`` as a process of its own, returned with its
    stderr so far once its progress line shows frames simulated."""
    import os
    import re
    import select
    import subprocess
    import sys
    import time

    path = tmp_path / "long.toml"
    path.write_text(LONG)
    proc = subprocess.Popen([sys.executable, "-m", "crowdmotion", "run", str(path), "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    err, fd = b"", proc.stderr.fileno()
    deadline = time.monotonic() + 180  # a cold numba cache compiles the kernels first
    while time.monotonic() < deadline:
        if select.select([fd], [], [], 1.0)[0]:
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                break
            err += chunk
            if re.search(rb"steps: [1-9][\d,]*/300,000 steps", err):  # a log's progress line (stderr is a pipe)
                return proc, err.decode(errors="replace")
    proc.kill()
    proc.wait()
    raise AssertionError(f"the run showed no frames: {err.decode(errors='replace')[-2000:]}")


def stop(proc, sig) -> tuple[int, str]:
    """Send ``sig`` to a run and wait for it: (exit status, the rest of its stderr)."""
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err.decode(errors="replace")


def test_sigterm_during_a_run_keeps_its_frames(tmp_path):
    import signal

    from crowdmotion import Trajectories

    out = tmp_path / "out"
    proc, _ = start_long_run(tmp_path, out)
    code, err = stop(proc, signal.SIGTERM)
    assert code == 143, err
    assert "SIGTERM" in err and "partial = true" in err and "Traceback" not in err, err
    traj = Trajectories.load(out / "trajectories.parquet")
    assert traj.n_frames > 10 and traj.metadata["partial"] is True
    summary = json.loads((out / "summary.json").read_text())
    assert summary["partial"] is True and summary["frames"] == traj.n_frames
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] is True and manifest["partial"] is True
    assert sorted(manifest["files"]) == ["summary.json", "trajectories.parquet"]
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "summary.json", "trajectories.parquet"]


def test_the_exit_codes_are_documented_in_help_and_readme(capsys):
    readme = (Path(__file__).parent.parent / "README.md").read_text()
    for argv in (["--help"], ["run", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = capsys.readouterr().out
        for code in ("0 ", "1 ", "2 ", "3 ", "130 ", "143 "):
            assert f"\n  {code}" in text, (argv, code)
            assert f"| {code.strip()} |" in readme, code
        assert "SIGTERM" in text and "partial = true" in text


@pytest.mark.parametrize("argv,option", [
    (["render", "RUN", "--max-frames", "0"], "--max-frames"),
    (["render", "RUN", "--max-frames", "ten"], "--max-frames"),
    (["render", "RUN", "--fps", "-24"], "--fps"),
    (["render", "RUN", "--fps", "1e9"], "--fps"),
    (["render", "RUN", "--trail", "nan"], "--trail"),
    (["render", "RUN", "--cell", "0"], "--cell"),
    (["render", "RUN", "--cell", "inf"], "--cell"),
    (["view", "RUN", "--max-frames", "-5"], "--max-frames"),
    (["export", "RUN", "--to", "csv", "--fps", "0"], "--fps"),
    (["sweep", "RUN", "--workers", "0"], "--workers"),
    (["sweep", "RUN", "--seeds", "5:2"], "--seeds"),
    (["sweep", "RUN", "--seeds", "-1,2"], "--seeds"),
    (["sweep", "RUN", "--seeds", "1,1"], "--seeds"),
    (["sweep", "RUN", "--seeds", "0:10000000000"], "--seeds"),
    (["run", "RUN", "--seed", "-1"], "--seed"),
    (["run", "RUN", "--seed", "1.5"], "--seed"),
    (["bench", "mdp", "--repeats", "0"], "--repeats"),
])
def test_a_bad_number_on_the_command_line_is_an_argparse_error_not_a_traceback(tmp_path, capsys, argv, option):
    argv = [str(tmp_path) if a == "RUN" else a for a in argv]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}" in err and "Traceback" not in err, err


def test_report_measures_an_rvo_run_s_groups_on_its_steps_not_the_relaxed_frames(tmp_path, capsys):
    # the paper's §6 observations are about the model's motion: summary.json and report agree,
    # whether from the run folder or a sweep of it
    import pyarrow.parquet as pq

    from crowdmotion import Trajectories
    from crowdmotion.metrics import group_report
    from tests.test_scenario import RVO

    path = tmp_path / "street.toml"
    path.write_text(RVO.replace("max_steps = 50", "max_steps = 400"))
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0
    assert main(["report", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    report = json.loads((out / "report.json").read_text())
    relaxed = group_report(Trajectories.load(out / "trajectories.parquet"))
    key = "heading_change_rate_rad_s"
    assert report["a"][key] == summary["groups"]["a"][key] != relaxed["a"][key]
    assert "measured by the run itself (summary.json" in capsys.readouterr().out
    lone = tmp_path / "lone"  # the file on its own: measured on its frames, and the report says so
    lone.mkdir()
    (lone / "t.parquet").write_bytes((out / "trajectories.parquet").read_bytes())
    assert main(["report", str(lone / "t.parquet")]) == 0
    assert "measured on the frames of t.parquet (no summary.json of the run beside it)" in capsys.readouterr().out
    assert main(["sweep", str(path), "--seeds", "0:2", "-o", str(tmp_path / "sw"), "-q"]) == 0
    row = pq.read_table(tmp_path / "sw" / "sweep.parquet").to_pylist()[0]
    assert json.loads(row["groups"])["a"][key] != group_report(Trajectories.load(row["file"]))["a"][key]
    capsys.readouterr()
    assert main(["report", str(tmp_path / "sw")]) == 0 and "mixing" in capsys.readouterr().out


def test_a_sweep_report_of_one_run_is_strict_json(tmp_path, capsys):
    # with one run a measure's confidence interval is infinite: JSON has no Infinity
    from tests.test_scenario import RVO

    path = tmp_path / "street.toml"
    path.write_text(RVO.replace("max_steps = 50", "max_steps = 400"))
    assert main(["sweep", str(path), "--seeds", "0:1", "-o", str(tmp_path / "sw"), "-q"]) == 0
    assert main(["report", str(tmp_path / "sw")]) == 0

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    report = json.loads((tmp_path / "sw" / "report.json").read_text(), parse_constant=refuse)
    assert report["runs"] == 1


@pytest.mark.parametrize("method,limit", [("mdp", "max_steps = 3"), ("rvo", "max_steps = 4"),
                                          ("pso", "iterations = 3")])
def test_a_run_that_ends_at_its_step_limit_says_so_and_which_setting_to_raise(tmp_path, capsys, method, limit):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace('method = "mdp"', f'method = "{method}"').replace("[mdp]\nmax_steps = 30",
                                                                                  f"[{method}]\n{limit}"))
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--plots", "none"]) == 0
    setting, value = limit.split(" = ")
    assert f"the run stopped at {method}.{setting} = {value}" in capsys.readouterr().out
    ended = json.loads((tmp_path / "out" / "summary.json").read_text())["ended_at_limit"]
    assert ended["setting"] == f"{method}.{setting}" and ended["value"] == int(value) and ended["simulated_s"] > 0


def test_a_run_where_everyone_arrives_names_no_limit(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace("max_steps = 30", "max_steps = 400"))
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--plots", "none"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["arrival_rate"] == 1.0 and "ended_at_limit" not in summary
    assert "the run stopped at" not in capsys.readouterr().out


def test_two_trajectory_files_exported_side_by_side_keep_their_own_exports(tmp_path, capsys):
    from crowdmotion import Trajectories

    for name, x in (("session1", 1.0), ("session2", 2.0)):
        Trajectories(np.full((3, 1, 2), x), 0.25).save(tmp_path / f"{name}.parquet")
        assert main(["export", str(tmp_path / f"{name}.parquet"), "--to", "csv"]) == 0
    assert Trajectories.load(tmp_path / "session1.csv").positions[0, 0, 0] == 1.0
    assert Trajectories.load(tmp_path / "session2.csv").positions[0, 0, 0] == 2.0
    capsys.readouterr()
    assert main(["export", str(tmp_path / "session1.csv"), "--to", "csv"]) == 2
    assert "session1.csv is the file being exported" in capsys.readouterr().err


def test_export_formats_are_named_in_any_case_and_a_missing_folder_is_refused_before_any_work(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    assert main(["run", str(path), "-o", str(tmp_path / "r"), "-q", "--plots", "none"]) == 0
    assert main(["export", str(tmp_path / "r"), "--to", "CSV"]) == 0 and (tmp_path / "r" / "trajectories.csv").is_file()
    assert main(["export", str(tmp_path / "r"), "--to", "usd", "-o", str(tmp_path / "none" / "x.usdc")]) == 2


def test_players_and_pictures_of_an_exported_file_are_named_after_it(tmp_path):
    # two exports viewed in one folder: each its own player, not one view.html written over
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    run = tmp_path / "r"
    assert main(["run", str(path), "-o", str(run), "-q", "--plots", "none"]) == 0
    assert main(["export", str(run), "--to", "csv", "-o", str(run / "a.csv")]) == 0
    assert main(["view", str(run / "a.csv")]) == 0 and (run / "a.view.html").is_file()
    assert main(["view", str(run)]) == 0 and (run / "view.html").is_file()
    assert main(["render", str(run / "a.csv"), "--to", "gif", "--max-frames", "2", "-q"]) == 0
    assert (run / "a.animation.gif").is_file() and (run / "a.density.png").is_file()


def test_report_gives_a_formation_s_time_to_goal_from_entering_and_says_how_each_method_measured(tmp_path, capsys):
    text = """
name = "march"
method = "formation"
[scene]
bounds = [[0.0, -6.0], [30.0, 6.0]]
[[groups]]
name = "soldiers"
count = 4
spawn = { shape = "point", position = [3.0, 0.0] }
goal = { shape = "point", position = [15.0, 0.0] }
formation = { kind = "block", rows = 2, cols = 2, spacing = 1.2 }
enter = { start = 2.0 }
"""
    path = tmp_path / "march.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 0
    capsys.readouterr()
    assert main(["report", str(out)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    report = json.loads((out / "report.json").read_text())
    arrived = summary["formation"]["soldiers"]["arrived_s"]
    assert report["soldiers"]["time_to_goal_s"] == pytest.approx(arrived - 2.0)  # from entering at 2 s
    assert "to goal: each formation as one unit, from entering" in printed and "an RVO run" not in printed


def _two_runs(tmp_path):
    """(the scenario file, two run folders of it: seeds 0 and 4)."""
    from tests.test_scenario import RVO

    path = tmp_path / "street.toml"
    path.write_text(RVO)
    one, two = tmp_path / "one", tmp_path / "two"
    assert main(["run", str(path), "-o", str(one), "-q", "--plots", "none"]) == 0
    assert main(["run", str(path), "-o", str(two), "-q", "--plots", "none", "--seed", "4"]) == 0
    return path, one, two


def test_an_export_never_replaces_another_run_s_file_nor_shrinks_a_run_to_one_frame(tmp_path, capsys):
    _, one, two = _two_runs(tmp_path)
    before = (two / "trajectories.parquet").read_bytes()
    capsys.readouterr()
    assert main(["export", str(one), "--to", "parquet", "-o", str(two / "trajectories.parquet")]) == 2
    assert "holds another run, and trajectories.parquet is one of its files" in capsys.readouterr().err
    assert (two / "trajectories.parquet").read_bytes() == before
    assert main(["export", str(one), "--to", "csv", "-o", str(tmp_path / "few.csv"), "--fps", "0.001"]) == 2
    assert "leaves one frame of the run's" in capsys.readouterr().err and not (tmp_path / "few.csv").exists()


def test_an_export_never_replaces_a_file_of_the_user_s_and_is_not_listed_as_another_run_s(tmp_path, capsys):
    from crowdmotion.outputs import read_manifest

    path, one, two = _two_runs(tmp_path)
    mine = tmp_path / "layout.usda"
    mine.write_text("#usda 1.0\n(my set)\n")
    capsys.readouterr()
    for dest in (mine, path.with_suffix(".csv")):
        if dest.suffix == ".csv":
            dest.write_text("shot,notes\n1,keep me\n")
        before = dest.read_bytes()
        assert main(["export", str(one), "--to", dest.suffix[1:], "-o", str(dest)]) == 2
        assert "exists and crowdmotion did not write it" in capsys.readouterr().err
        assert dest.read_bytes() == before
    assert main(["export", str(one), "--to", "usda", "-o", str(mine), "--overwrite"]) == 0
    assert main(["export", str(one), "--to", "usda", "-o", str(mine)]) == 0  # an earlier export: replaced
    # into another run's folder: written, not listed among that run's files
    assert main(["export", str(one), "--to", "csv", "-o", str(two / "one.csv")]) == 0
    assert "one.csv" not in read_manifest(two)["files"] and (two / "one.csv").is_file()
    # into its own folder: listed, so its run --overwrite removes it
    assert main(["export", str(one), "--to", "csv"]) == 0
    assert "trajectories.csv" in read_manifest(one)["files"]


def test_a_run_whose_reader_leaves_early_still_writes_its_files(tmp_path, monkeypatch):
    # `crowdmotion run x.toml | head -1`: printing into the closed pipe raised
    # BrokenPipeError and the run, simulated, was never written
    import io

    from tests.test_scenario import RVO

    class Closed(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    path = tmp_path / "street.toml"
    path.write_text(RVO)
    monkeypatch.setattr("sys.stdout", Closed())
    monkeypatch.setattr("sys.stderr", Closed())
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--plots", "none"]) == 0
    assert (tmp_path / "out" / "trajectories.parquet").is_file() and (tmp_path / "out" / "summary.json").is_file()


def test_the_export_root_motion_line_prints_p95_and_max_at_one_precision():
    """A max just under 0.05 printed to 0.1 read 'p95 0.05 m/s², max 0.0': a max below its
    own p95 (walkers at constant speeds, as `crowdmotion export` prints it)."""
    import crowdmotion as cm
    from crowdmotion.cli import _file_root_motion

    t = np.arange(200) / 24
    n = 40
    pos = np.zeros((len(t), n, 2))
    pos[..., 0] = t[:, None] * np.linspace(0.9, 1.5, n)
    pos[..., 1] = np.arange(n) + 0.2 * np.sin(0.5 * t[:, None] + np.arange(n))
    line = _file_root_motion(cm.Trajectories(pos, 1 / 24, radius=0.25, metadata={"dim": 2}))
    values = [float(v) for v in re.findall(r"(?:p95|max) (\d+\.\d+)", line)]
    assert len(values) == 4, line
    acc_p95, acc_max, turn_p95, turn_max = values
    assert acc_max >= acc_p95 and turn_max >= turn_p95, line
