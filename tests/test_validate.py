"""`validate` is `run` (issue 15): what a run would refuse, validate refuses first, in the
scenario file's own terms; runs never quietly give something other than what was asked."""

import json

import pytest

from crowdmotion.cli import main

BASE = """
name = "{name}"
method = "{method}"
[scene]
bounds = {bounds}
obstacles = [{{ shape = "box", lower = [20, 5], upper = [25, 15] }}]
[[groups]]
name = "walkers"
count = {count}
spawn = {spawn}
goal = {goal}
"""


def scenario(tmp_path, method="rvo", count=9, spawn='{ shape = "rect", lower = [2, 5], upper = [8, 15] }',
             goal='{ shape = "point", position = [28, 10] }', bounds="[[0, 0], [30, 20]]", extra="", name="s"):
    path = tmp_path / f"{name}.toml"
    path.write_text(BASE.format(name=name, method=method, count=count, spawn=spawn, goal=goal, bounds=bounds)
                    + extra)
    return path


def refused(capsys, argv, *words):
    """The command exits 2 and its error names every one of ``words``."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err, err
    return err


def test_a_formation_of_16_with_a_point_spawn_is_refused_not_shrunk_to_one(tmp_path, capsys):
    path = scenario(tmp_path, "formation", 16, spawn='{ shape = "point", position = [5, 10] }')
    refused(capsys, ["validate", str(path)], str(path), "group 'walkers'", "count = 16",
            "1 position", 'formation = { kind = "block"')
    refused(capsys, ["run", str(path), "-o", str(tmp_path / "out"), "-q"], "count = 16")


def test_a_formation_without_a_template_is_told_the_toml_to_write(tmp_path, capsys):
    path = scenario(tmp_path, "formation", 16)
    refused(capsys, ["validate", str(path)], "group 'walkers'", 'formation = { kind = "block"', "[[groups]]")


@pytest.mark.parametrize("method", ["rvo", "mdp", "pso"])
def test_a_goal_inside_an_obstacle_is_refused_by_validate(tmp_path, capsys, method):
    path = scenario(tmp_path, method, goal='{ shape = "point", position = [22, 10] }')
    refused(capsys, ["validate", str(path)], str(path), "'walkers'", "goal", "22")


def test_a_goal_inside_an_obstacle_names_the_obstacle_in_toml_terms(tmp_path, capsys):
    path = scenario(tmp_path, goal='{ shape = "point", position = [22, 10] }')
    err = refused(capsys, ["validate", str(path)], "scene.obstacles.0 (box [20, 5]-[25, 15])")
    assert "Points(" not in err and "Rect(" not in err, "no internal class names"


def test_500_agents_in_a_2_by_2_spawn_are_refused_at_once(tmp_path, capsys):
    path = scenario(tmp_path, count=500, spawn='{ shape = "rect", lower = [2, 2], upper = [4, 4] }')
    refused(capsys, ["validate", str(path)], "spawn: rect [2, 2]-[4, 4] has room for at most", "count = 500")


def test_a_spawn_inside_an_obstacle_is_told_it_has_no_free_room_not_a_count(tmp_path, capsys):
    path = scenario(tmp_path, spawn='{ shape = "rect", lower = [21, 6], upper = [24, 14] }')
    err = refused(capsys, ["validate", str(path)], "spawn: rect [21, 6]-[24, 14] has no free room", "obstacles")
    assert "room for at most 0" not in err


def test_mdp_spawn_with_too_few_cells_is_refused_by_validate(tmp_path, capsys):
    path = scenario(tmp_path, "mdp", count=40, spawn='{ shape = "rect", lower = [2, 2], upper = [4, 4] }')
    refused(capsys, ["validate", str(path)], "spawn: rect [2, 2]-[4, 4] has", "count = 40")


def test_a_3d_scene_with_rvo_is_refused_by_validate(tmp_path, capsys):
    path = tmp_path / "drones.toml"
    path.write_text("""
method = "rvo"
[scene]
bounds = [[0, 0, 0], [30, 20, 10]]
[[groups]]
name = "drones"
count = 5
spawn = { shape = "rect", lower = [2, 2, 2], upper = [8, 8, 8] }
goal = { shape = "point", position = [22, 10, 5] }
""")
    refused(capsys, ["validate", str(path)], "method 'rvo' works in 2D", "the scene is 3D", "mdp")


def test_a_goal_walled_off_from_the_spawn_is_refused_by_validate(tmp_path, capsys):
    wall = '\nobstacles = [{ shape = "box", lower = [14, 0], upper = [15, 20] }]\n'
    for method in ("rvo", "mdp"):
        path = scenario(tmp_path, method, name=f"walled_{method}")
        path.write_text(path.read_text().replace(
            'obstacles = [{ shape = "box", lower = [20, 5], upper = [25, 15] }]', wall.strip()))
        refused(capsys, ["validate", str(path)], "'walkers'", "cannot be reached" if method == "rvo" else "reach")


def test_validate_gives_a_size_estimate(tmp_path, capsys):
    path = scenario(tmp_path, count=50, spawn='{ shape = "rect", lower = [2, 2], upper = [12, 18] }')
    assert main(["validate", str(path)]) == 0
    out = capsys.readouterr().out
    assert "50 agents x at most 2000 steps = 100,000 agent-steps" in out and "MiB in memory" in out


def test_an_unwritable_output_folder_is_refused_before_simulating(tmp_path, capsys):
    path = scenario(tmp_path)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    refused(capsys, ["validate", str(path), "-o", str(blocker / "out")], "is a file")
    refused(capsys, ["run", str(path), "-o", str(blocker / "out"), "-q"], "is a file")
    assert not (tmp_path / "out").exists()


def test_an_output_folder_holds_one_run(tmp_path, capsys):
    mdp = scenario(tmp_path, "mdp", name="m", extra="[mdp]\nmax_steps = 40\n")
    rvo = scenario(tmp_path, "rvo", name="r", extra="[rvo]\nmax_steps = 40\n")
    out = tmp_path / "out"
    assert main(["run", str(mdp), "-o", str(out), "-q"]) == 0
    assert (out / "values.png").is_file()
    refused(capsys, ["run", str(rvo), "-o", str(out), "-q"], "holds an earlier run", "--overwrite")
    assert main(["run", str(rvo), "-o", str(out), "-q", "--overwrite"]) == 0
    assert not (out / "values.png").exists(), "the MDP run's value field is gone with it"
    assert json.loads((out / "summary.json").read_text())["method"] == "rvo"


def test_validate_notes_an_earlier_run_in_the_output_folder_that_run_refuses(tmp_path, capsys, monkeypatch):
    # iterating on a scenario whose default folder (out/<name>) holds the last run: the scenario is fine
    monkeypatch.chdir(tmp_path)
    path = scenario(tmp_path, "rvo", name="r", extra="[rvo]\nmax_steps = 40\n")
    out = tmp_path / "out" / "r"
    assert main(["run", str(path), "-q"]) == 0 and (out / "summary.json").is_file()
    capsys.readouterr()
    before = sorted(p.name for p in out.iterdir())
    assert main(["validate", str(path)]) == 0
    said = capsys.readouterr().out
    assert ": OK:" in said and "note: output folder out/r holds an earlier run" in said
    assert "--overwrite" in said and "-o" in said
    assert main(["validate", str(path), "--overwrite"]) == 0
    assert "note:" not in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == before, "validate writes nothing"
    # run still refuses it; a scenario error is still an error with such a folder
    refused(capsys, ["run", str(path), "-q"], "holds an earlier run", "--overwrite")
    path.write_text(path.read_text().replace("[rvo]\n", "[rvo]\ntime_stepp = 0.1\n"))
    refused(capsys, ["validate", str(path)], "time_stepp")


def test_a_run_that_ends_with_collisions_exits_non_zero_unless_allowed(tmp_path, capsys):
    # the paper's own Algorithm 3 without the crossing test lets diagonal moves cross (at
    # the cell centres: relaxed paths push the bodies apart)
    path = scenario(tmp_path, "mdp", count=60, spawn='{ shape = "rect", lower = [1, 1], upper = [12, 19] }',
                    extra='[mdp]\nforbid_crossing = false\ncorner_cutting = true\nmax_steps = 80\nsmoothing = "none"\n')
    assert main(["run", str(path), "-o", str(tmp_path / "a"), "-q"]) == 3
    assert "--allow-collisions" in capsys.readouterr().err
    assert (tmp_path / "a" / "summary.json").is_file(), "the files are kept for inspection"
    assert main(["run", str(path), "-o", str(tmp_path / "b"), "-q", "--allow-collisions"]) == 0


def test_built_in_scenes_run_by_name_and_typos_get_a_suggestion(tmp_path, capsys):
    assert main(["run", "mdp_robots_2d", "-o", str(tmp_path / "r"), "-q"]) == 0
    refused(capsys, ["run", "mdp_robot_2d"], "did you mean the built-in 'mdp_robots_2d'")
    assert main(["report", str(tmp_path / "r")]) == 0
    row = json.loads((tmp_path / "r" / "report.json").read_text())["robots"]
    assert row["time_to_goal_s"] is not None, "report reads the arrival times the run measured"


def test_library_warnings_print_as_one_clean_line(tmp_path, capsys):
    path = scenario(tmp_path, "mdp", count=20, extra='[mdp]\nsmoothing = "catmull-rom"\nmax_steps = 60\n')
    assert main(["run", str(path), "-o", str(tmp_path / "o"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "catmull-rom smoothing would have" in err
    for line in err.splitlines():
        assert line.startswith("crowdmotion: warning: ") and ".py" not in line, err


def test_a_typo_gets_a_did_you_mean_and_the_group_by_name(tmp_path, capsys):
    path = scenario(tmp_path, extra="[rvo]\ntime_stp = 0.1\n")
    path.write_text(path.read_text().replace("count = 9", "count = 9\nradus = 0.3"))
    refused(capsys, ["validate", str(path)], "groups.0.radus (group 'walkers')", "did you mean 'radius'?",
            "rvo.time_stp", "did you mean 'time_step'?")


def test_a_pso_point_spawn_for_four_is_refused_by_validate_as_run_would(tmp_path, capsys):
    path = scenario(tmp_path, "pso", count=4, spawn='{ shape = "point", position = [5, 10] }')
    refused(capsys, ["validate", str(path)], "1 points given for count = 4")


def test_the_scenario_reference_explains_every_field_in_toml_terms():
    from pathlib import Path

    text = (Path(__file__).parent.parent / "docs" / "scenario-reference.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith("| `")]
    empty = [r.split("|")[1] for r in rows if r.rstrip(" |").endswith("|") or r.split("|")[-2].strip() == ""]
    assert not empty, f"fields without a meaning: {empty}"
    assert "UnionType" not in text and "NoneType" not in text and "Annotated" not in text
    assert "| obstacle `polygon` | yes | yes | — | yes |" in text, "per-method support, PSO refuses polygons"
    assert "`O+`" in text and "`N-`" in text, "the personality names"


@pytest.mark.parametrize("method,extra", [
    ("rvo", "[rvo]\nmax_steps = 400\n"),
    ("mdp", "[mdp]\nmax_steps = 400\nstop_when_done = false\n"),
    ("pso", "[pso]\niterations = 400\nstop_when_done = false\n"),
    ("formation", "[formation]\nmax_steps = 400\n"),
])
def test_ctrl_c_stops_cleanly_and_keeps_the_frames_so_far(tmp_path, capsys, monkeypatch, method, extra):
    from crowdmotion.progress import LineBar

    calls = {"n": 0}
    done = LineBar.done  # pytest's stderr is not a terminal: the run reports progress in lines

    def press_ctrl_c(self, n):  # the user presses Ctrl-C during the run
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        done(self, n)

    monkeypatch.setattr(LineBar, "done", press_ctrl_c)
    group = 'formation = { kind = "block", rows = 3, cols = 3, spacing = 1.2 }\n' if method == "formation" else ""
    path = scenario(tmp_path, method, extra=extra)
    path.write_text(path.read_text().replace("count = 9\n", "count = 9\n" + group))
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out)]) == 130
    assert "interrupted: kept the" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["partial"] is True and summary["frames"] > 1
    assert (out / "trajectories.parquet").is_file()
    if method == "rvo":  # the steps so far as simulated, at once: not relaxed, and said so
        assert summary["smoothing"] == {"kind": "none"}


def test_a_pso_clamp_faster_than_the_groups_max_speed_is_said_not_silent(tmp_path, capsys):
    path = scenario(tmp_path, "pso")  # max_speed 1.5 m/s; v_max 0.5 per axis per 0.25 s = 2.83 m/s in 2D
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    assert "group 'walkers' (groups.0): pso.v_max [0.5, 0.5]" in err and "2.83 m/s" in err and "max_speed 1.5" in err


def test_a_formation_walled_off_from_its_goal_is_refused_by_validate(tmp_path, capsys):
    path = scenario(tmp_path, "formation")
    path.write_text(path.read_text()
                    .replace('obstacles = [{ shape = "box", lower = [20, 5], upper = [25, 15] }]',
                             'obstacles = [{ shape = "box", lower = [14, 0], upper = [15, 20] }]')
                    .replace("count = 9\n", 'count = 9\nformation = { kind = "block", rows = 3, cols = 3 }\n'))
    refused(capsys, ["validate", str(path)], "group 'walkers' (groups.0) goal", "walls close the way")


def test_files_say_a_whole_frame_rate_and_export_resamples_to_the_one_asked(tmp_path, capsys):
    import sqlite3

    import numpy as np

    from crowdmotion.trajectories import Trajectories

    pos = np.cumsum(np.full((11, 2, 2), 0.1), axis=0)
    pos[:, 1, 1] += 3
    run = tmp_path / "run"
    run.mkdir()
    Trajectories(pos, 0.2000000000000028).save(run / "trajectories.parquet")  # a resampled run's dt
    assert main(["export", str(run), "--to", "sqlite"]) == 0
    con = sqlite3.connect(run / "trajectories.sqlite")
    assert con.execute("select value from metadata where key = 'fps'").fetchone()[0] == "5.0"
    assert main(["export", str(run), "--to", "csv", "--fps", "24", "-o", str(run / "t24.csv")]) == 0
    assert "at 24 fps" in capsys.readouterr().out
    assert Trajectories.load(run / "t24.csv").n_frames == 49


def test_a_speed_range_beyond_max_speed_is_refused_by_validate(tmp_path, capsys):
    path = scenario(tmp_path)
    path.write_text(path.read_text().replace("count = 9\n", "count = 9\nattributes = { pref_speed_range = [1.0, 2.0] }\n"))
    refused(capsys, ["validate", str(path)], "group 'walkers'", "pref_speed_range", "max_speed")


def test_validate_refuses_a_run_larger_than_max_memory_before_placing_anyone(tmp_path, capsys, monkeypatch):
    from crowdmotion.rvo import adapter

    def never(*args):  # placing a million agents is the slow part validate must not reach
        raise AssertionError("check_scenario ran")

    monkeypatch.setattr(adapter, "check_scenario", never)
    path = scenario(tmp_path, count=1_000_000, spawn='{ shape = "rect", lower = [0, 0], upper = [30, 20] }',
                    bounds="[[0, 0], [3000, 2000]]")
    err = refused(capsys, ["validate", str(path), "--max-memory", "1G"], str(path), "59.6 GiB of trajectories",
                  "1,000,000 agents x 2,000 steps", "1.0 GiB", "rvo.max_steps")
    assert "Traceback" not in err
    refused(capsys, ["run", str(path), "--max-memory", "1G", "-o", str(tmp_path / "o")], "59.6 GiB")
    assert not (tmp_path / "o").exists()


def test_validate_refuses_a_run_larger_than_the_available_memory(tmp_path, capsys, monkeypatch):
    import crowdmotion.memory

    monkeypatch.setattr(crowdmotion.memory, "available_memory", lambda: 1 << 20)
    path = scenario(tmp_path, count=50, spawn='{ shape = "rect", lower = [2, 2], upper = [12, 18] }')
    refused(capsys, ["validate", str(path)], "3.1 MiB of trajectories", "1.0 MiB, the memory available now")
    assert main(["validate", str(path), "--max-memory", "4M"]) == 0  # the steps and their relaxed frames


def test_the_size_estimate_counts_resampled_frames(tmp_path):
    from crowdmotion.scenario import load_scenario, size_estimate

    path = scenario(tmp_path, "pso", count=10, extra="[pso]\niterations = 100\nfps = 24\n")
    est = size_estimate(load_scenario(path))
    assert (est.steps, est.frames, est.seconds) == (100, 601, 25.0)  # 100 iterations of 0.25 s at 24 fps
    assert est.bytes == (101 + 601) * 10 * 2 * 8


def test_the_size_estimate_counts_an_rvo_runs_relaxed_frames_beside_its_steps(tmp_path):
    from crowdmotion.scenario import load_scenario, size_estimate

    relaxed = size_estimate(load_scenario(scenario(tmp_path, "rvo", count=10, extra="[rvo]\nmax_steps = 100\n")))
    plain = size_estimate(load_scenario(scenario(tmp_path, "rvo", count=10, name="plain",
                                                 extra='[rvo]\nmax_steps = 100\nsmoothing = "none"\n')))
    assert (relaxed.frames, plain.frames) == (101, 101)
    assert (relaxed.bytes, plain.bytes) == (2 * 101 * 10 * 2 * 8, 101 * 10 * 2 * 8)


@pytest.mark.parametrize("size", ["lots", "0", "-1G", "1e400"])
def test_a_bad_max_memory_is_an_argparse_error(tmp_path, capsys, size):
    with pytest.raises(SystemExit) as exc:
        main(["validate", str(scenario(tmp_path)), "--max-memory", size])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "argument --max-memory" in err and "Traceback" not in err


def test_the_spawn_room_lower_bound_never_promises_more_room_than_the_sampled_count():
    # validating a spawn region skips sampling its free area when a lower bound already
    # leaves room; that bound must stay below the sampled count (up to the lattice)
    import numpy as np

    import crowdmotion as cm
    from crowdmotion.checks import _room_at_least, spawn_room
    from crowdmotion.groups import Group, Rect

    rng = np.random.default_rng(0)
    for trial in range(40):
        obstacles = [cm.Circle(rng.uniform(0, 20, 2), rng.uniform(0.2, 2.0)) for _ in range(rng.integers(0, 6))]
        lo = rng.uniform(0, 14, 2)
        obstacles += [cm.Box(lo, lo + rng.uniform(0.5, 5, 2))] if trial % 2 else []
        scene = cm.Scene(bounds=([0, 0], [20, 20]), obstacles=obstacles)
        a = rng.uniform(0, 12, 2)
        group = Group("g", 1, spawn=Rect(a, a + rng.uniform(1, 8, 2)), goal=Rect([0, 0], [1, 1]),
                      radius=float(rng.uniform(0.1, 0.5)))
        bound = _room_at_least(scene, group, 0.05)
        room, _ = spawn_room(scene, group, 0.05)
        assert bound <= room * 1.02 + 1, (trial, bound, room)


def test_a_field_of_another_formation_kind_is_named_as_such_not_suggested_back(tmp_path, capsys):
    path = scenario(tmp_path, "formation", 10, spawn='{ shape = "point", position = [5, 10] }',
                    extra="")
    text = path.read_text().replace('goal = { shape = "point", position = [28, 10] }',
                                    'goal = { shape = "point", position = [28, 10] }\n'
                                    'formation = { kind = "wedge", rows = 4, cols = 6, spacing = 1.2 }')
    path.write_text(text)
    err = refused(capsys, ["validate", str(path)], "formation.wedge.cols",
                  "is not a field here ('cols' belongs to another table or kind, not this one)")
    assert "did you mean 'cols'" not in err


def test_a_folder_given_as_the_scenario_is_named_a_folder(tmp_path, capsys):
    (tmp_path / "mine.toml").write_text("")
    refused(capsys, ["run", str(tmp_path)], "is a folder, not a scenario file (it holds mine.toml)")


def test_every_group_s_first_problem_is_named_at_once(tmp_path, capsys):
    # a file with two groups wrong said only the first; the user fixed one per run
    from crowdmotion.cli import main

    path = tmp_path / "two.toml"
    path.write_text("""
name = "two"
method = "rvo"
[scene]
bounds = [[0.0, 0.0], [20.0, 10.0]]
obstacles = [{ shape = "box", lower = [2.0, 2.0], upper = [8.0, 8.0] }]
[[groups]]
name = "a"
count = 5
spawn = { shape = "rect", lower = [1.0, 1.0], upper = [5.0, 9.0] }
goal = { shape = "rect", lower = [3.0, 3.0], upper = [6.0, 6.0] }
[[groups]]
name = "b"
count = 5
spawn = { shape = "rect", lower = [10.0, 1.0], upper = [12.0, 3.0] }
goal = { shape = "point", position = [30.0, 5.0] }
""")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "2 problems" in err and "group 'a' (groups.0) goal" in err and "group 'b' (groups.1) goal" in err


def test_a_method_s_parameters_built_in_python_name_the_field_and_the_value():
    # rvo.RVOParams(timestep=0.1) raised pydantic's error with its web address
    from crowdmotion import rvo
    from crowdmotion.formation.params import FormationParams

    typo = r"^rvo\.timestep: is not a known field \(got 0\.1\); did you mean 'time_step'\?$"
    with pytest.raises(ValueError, match=typo):
        rvo.RVOParams(timestep=0.1)
    with pytest.raises(ValueError, match=r"^formation\.fps: must be more than 0 \(got 0\)$"):
        FormationParams(fps=0)


def test_fifty_drones_on_a_launch_pad_thinner_than_a_body_pass_validate(tmp_path, capsys):
    # a 20 x 10 m pad 0.1 m thick in a 3D scene was refused by its volume ("room for about 34")
    path = tmp_path / "pad.toml"
    path.write_text('name = "pad"\nmethod = "pso"\n[scene]\nbounds = [[-30, -30, 0], [30, 30, 50]]\n'
                    '[[groups]]\nname = "drones"\ncount = 50\nradius = 0.3\n'
                    'spawn = { shape = "rect", lower = [-10, 15, 0.3], upper = [10, 25, 0.4] }\n'
                    'goal = { shape = "point", position = [0, 0, 25] }\n')
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("z, ok", [(0.0, False), (0.5, True)])
def test_a_flat_landing_pad_goal_is_judged_in_its_plane(tmp_path, capsys, z, ok):
    # a goal rect with lower z = upper z (a landing pad) was "outside scene.bounds" wherever
    # it lay: a flat region gave no sample points; on the floor itself a body cannot stand
    path = tmp_path / "land.toml"
    path.write_text('name = "land"\nmethod = "pso"\n[scene]\nbounds = [[0, 0, 0], [40, 40, 30]]\n'
                    '[[groups]]\nname = "drones"\ncount = 20\nradius = 0.3\n'
                    'spawn = { shape = "rect", lower = [5, 5, 1], upper = [15, 15, 2] }\n'
                    f'goal = {{ shape = "rect", lower = [25, 25, {z}], upper = [35, 35, {z}] }}\n')
    code = main(["validate", str(path)])
    err = capsys.readouterr().err
    if ok:
        assert code == 0, err
    else:
        assert code == 2 and "outside scene.bounds" not in err
        assert "keeps an agent of radius 0.3 m clear" in err and "from the walls of scene.bounds" in err
