"""``crowdmotion demo``: scenes side by side in worker processes, the same files as one
after another."""

from types import SimpleNamespace

import numpy as np
import pytest

from crowdmotion.cli import builtin_scenarios, main
from crowdmotion.demo import DemoScene, interleave, run_one, run_parallel
from crowdmotion.trajectories import Trajectories


def test_interleave_takes_one_scene_of_each_method_in_turn():
    scenes = [SimpleNamespace(method=m, name=n) for m, n in
              [("rvo", "r1"), ("mdp", "m1"), ("rvo", "r2"), ("formation", "f1"), ("rvo", "r3"), ("mdp", "m2")]]
    assert [s.name for s in interleave(scenes)] == ["f1", "m1", "r1", "m2", "r2", "r3"]
    assert interleave([]) == []


def test_workers_write_what_one_process_writes(tmp_path):
    wanted = {"pso_gathering", "mdp_robots_2d"}
    scenes = [DemoScene.read(p) for p in builtin_scenarios() if p.stem in wanted]
    assert {(sc.name, sc.method) for sc in scenes} == {("pso_gathering", "pso"), ("mdp_robots_2d", "mdp")}
    lines = []
    done = run_parallel(scenes, tmp_path / "side", jobs=2, progress=False,
                        file=SimpleNamespace(write=lines.append, flush=lambda: None))
    assert {d.name for d in done} == wanted and all(d.error is None for d in done)
    assert sum(name in "".join(lines) for name in wanted) == 2  # a line per scene as it finishes
    for sc in scenes:
        alone = run_one(sc.path, tmp_path / "alone" / sc.name)
        assert alone.error is None and "agent overlaps 0" in alone.headline
        a = Trajectories.load(tmp_path / "side" / sc.name / "trajectories.parquet")
        b = Trajectories.load(tmp_path / "alone" / sc.name / "trajectories.parquet")
        np.testing.assert_array_equal(a.positions, b.positions)
        assert (tmp_path / "side" / sc.name / "paths.png").stat().st_size > 10_000


def test_a_scene_that_fails_is_reported_and_the_demo_exits_non_zero(tmp_path, monkeypatch, capsys):
    import crowdmotion.demo as demo

    calls = []

    def fake(scenes, root, jobs, progress=True, file=None):
        calls.append((sorted(sc.name for sc in scenes), jobs))
        return [demo.SceneDone("rvo_doorway", "", 0.1, "RuntimeError: boom"),
                demo.SceneDone("rvo_street_O", "80 agents", 0.1)]

    monkeypatch.setattr(demo, "run_parallel", fake)
    assert main(["demo", "-o", str(tmp_path), "-q", "-j", "4", "--only", "rvo_doorway", "rvo_street_O"]) == 1
    assert calls == [(["rvo_doorway", "rvo_street_O"], 2)]  # no more processes than scenes
    assert "1 scene(s) failed: rvo_doorway" in capsys.readouterr().err


def test_demo_refuses_unknown_scenes_and_bad_job_counts(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path / "d"), "--only", "rvo_doorway", "rvo_dorway"]) == 2
    assert "no built-in scene named 'rvo_dorway'" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()
    (tmp_path / "afile").write_text("")
    assert main(["demo", "-o", str(tmp_path / "afile" / "demo"), "--only", "rvo_doorway"]) == 2
    assert "afile is a file" in capsys.readouterr().err  # said once, before any scene runs
    for wrong in ("0", "-2", "two"):
        with pytest.raises(SystemExit):
            main(["demo", "-o", str(tmp_path / "d"), "-j", wrong])
        assert "at least 1" in capsys.readouterr().err


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_scene_whose_name_leads_out_of_the_demo_folder_is_refused_before_it_runs(tmp_path, monkeypatch, capsys,
                                                                                 jobs):
    import crowdmotion.cli as cli

    scenes = [tmp_path / "escape.toml", tmp_path / "twin.toml"]  # the demo lists them by name, unchecked
    for path in scenes:
        path.write_text('name = "../../escaped"\nmethod = "mdp"\n')
    monkeypatch.setattr(cli, "builtin_scenarios", lambda: scenes)
    assert main(["demo", "-o", str(tmp_path / "d" / "demo"), "-q", "-j", jobs]) == 2
    assert "'../../escaped'" in capsys.readouterr().err
    assert not (tmp_path / "escaped").exists() and not (tmp_path / "d" / "demo").exists()


def test_every_builtin_scene_file_names_itself_as_the_demo_lists_it():
    from crowdmotion.scenario import load_scenario

    for path in builtin_scenarios():
        listed, loaded = DemoScene.read(path), load_scenario(path)
        assert (listed.name, listed.method, listed.description) == \
            (loaded.spec.name, loaded.method, loaded.spec.description)

