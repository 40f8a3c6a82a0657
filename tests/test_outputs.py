"""How a run's pictures are shared out between the picture process's parts."""

import sys

import pytest

from crowdmotion.outputs import OutputFolderError, folder_inside, picture_parts

FORMATION_PLOTS = ["paths", "values", "snapshots", "player"]
SPLIT = {"snapshots": ("snapshots-figure", "snapshots-animation")}


def test_every_picture_is_in_exactly_one_part_in_its_given_order():
    for parts in (1, 2, 3, 8):
        got = picture_parts(FORMATION_PLOTS, parts, SPLIT)
        flat = [n for part in got for n in part]
        assert sorted(flat) == sorted(["paths", "values", "snapshots-figure", "snapshots-animation", "player"])
        for part in got:
            order = ["paths", "values", "snapshots-figure", "snapshots-animation", "player"]
            assert part == sorted(part, key=order.index)
        assert len(got) == min(parts, 5)


def test_the_formation_gif_is_drawn_apart_from_the_rest_on_two_cores():
    assert picture_parts(FORMATION_PLOTS, 2, SPLIT) == [["snapshots-animation"],
                                                         ["paths", "values", "snapshots-figure", "player"]]


def test_one_part_keeps_the_names_as_given_without_a_split():
    assert picture_parts(FORMATION_PLOTS, 1) == [FORMATION_PLOTS]
    assert picture_parts(["paths", "player"], 2) == [["paths"], ["player"]]


@pytest.mark.parametrize("name", ["..", "../x", "a/../../x", "/tmp/elsewhere", "", ".", "a\x00b"])
def test_a_name_that_leads_out_of_the_output_root_is_refused_even_past_the_schema(tmp_path, name):
    with pytest.raises(OutputFolderError, match="outside"):
        folder_inside(tmp_path / "out", name)


def test_a_plain_name_gives_a_folder_inside_the_output_root(tmp_path):
    assert folder_inside(tmp_path / "out", "street") == tmp_path / "out" / "street"
    assert folder_inside(tmp_path / "out", "a/b") == tmp_path / "out" / "a" / "b"  # nested, still inside


# -- the output folder a run holds: lock, manifest, --overwrite, temporary files, failures --

import errno  # noqa: E402
import json  # noqa: E402
from contextlib import contextmanager  # noqa: E402

from crowdmotion.cli import main  # noqa: E402
from tests.test_scenario import GOOD  # noqa: E402


def _scenario(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    return path


def _files(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_a_second_run_into_a_busy_folder_is_refused(tmp_path, capsys):
    import signal

    from tests.test_cli import start_long_run, stop

    out = tmp_path / "out"
    proc, _ = start_long_run(tmp_path, out)
    try:
        path = _scenario(tmp_path)
        for argv in (["run", str(path), "-o", str(out), "-q"], ["run", str(path), "-o", str(out), "-q", "--overwrite"],
                     ["validate", str(path), "-o", str(out)]):
            assert main(argv) == 2, argv
            err = capsys.readouterr().err
            assert f"output folder {out} is in use by another crowdmotion run (process {proc.pid})" in err, err
        assert _files(out) == [".crowdmotion.lock"]  # the refused runs wrote nothing
    finally:
        code, err = stop(proc, signal.SIGINT)
    assert code == 130, err
    assert main(["run", str(path), "-o", str(out), "-q", "--overwrite"]) == 0  # free again once it ended


def test_overwrite_removes_only_the_earlier_runs_files(tmp_path, capsys):
    path = _scenario(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths,player"]) == 0
    assert main(["report", str(out)]) == 0  # made from the run afterwards: listed with it
    (out / "notes.txt").write_text("mine")
    (out / "density.png").write_bytes(b"a picture of my own, by a name a run could write")
    assert json.loads((out / "manifest.json").read_text())["files"] == [
        "trajectories.parquet", "summary.json", "paths.png", "view.html", "report.json"]
    capsys.readouterr()
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 2
    assert f"output folder {out} holds an earlier run" in capsys.readouterr().err
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none", "--overwrite"]) == 0
    assert _files(out) == ["density.png", "manifest.json", "notes.txt", "summary.json", "trajectories.parquet"]
    assert (out / "notes.txt").read_text() == "mine" and (out / "density.png").read_bytes().startswith(b"a picture")
    assert json.loads((out / "manifest.json").read_text())["files"] == ["trajectories.parquet", "summary.json"]


def test_a_folder_with_files_but_no_manifest_is_refused(tmp_path, capsys):
    path = _scenario(tmp_path)
    out = tmp_path / "old"
    out.mkdir()
    for name in ("summary.json", "report.json", ".hidden"):  # an earlier version's run, or anyone's files
        (out / name).write_text("{}")
    for extra in ([], ["--overwrite"]):
        assert main(["run", str(path), "-o", str(out), "-q", *extra]) == 2
        err = capsys.readouterr().err
        assert f"output folder {out} holds files no crowdmotion run listed (.hidden, report.json, summary.json; " \
               f"no manifest.json)" in err and "Traceback" not in err, err
    assert main(["validate", str(path), "-o", str(out), "--overwrite"]) == 2
    assert "no manifest.json" in capsys.readouterr().err
    assert _files(out) == [".hidden", "report.json", "summary.json"]


def test_a_damaged_manifest_is_refused_naming_it(tmp_path, capsys):
    path = _scenario(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    for text in ("{not json", '{"files": ["../../elsewhere.txt"]}', '{"files": "summary.json"}'):
        (out / "manifest.json").write_text(text)
        assert main(["run", str(path), "-o", str(out), "-q", "--overwrite"]) == 2
        err = capsys.readouterr().err
        assert f"{out / 'manifest.json'} is not a crowdmotion run manifest" in err, err
    assert _files(out) == ["manifest.json"]


def test_stale_temp_files_are_removed(tmp_path, capsys):
    path = _scenario(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 0
    stale = [".trajectories.parquet.a1b2c3d4.tmp", ".paths.png.zz_9x8y7.tmp", ".trajectories.sqlite.q1w2e3r4.tmp-journal",
             ".trajectories.usdc.k9j8h7g6.usdc", ".crowdmotion-probe-abc123"]  # writes killed outright
    for name in stale:
        (out / name).write_bytes(b"half")
    (out / ".keep.tmp").write_text("not a name a write of ours makes")
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none", "--overwrite"]) == 0
    assert _files(out) == [".keep.tmp", "manifest.json", "summary.json", "trajectories.parquet"]
    fresh = tmp_path / "fresh"  # a folder with nothing but what killed writes left counts as empty
    fresh.mkdir()
    for name in stale:
        (fresh / name).write_bytes(b"half")
    assert main(["run", str(path), "-o", str(fresh), "-q", "--plots", "none"]) == 0
    assert _files(fresh) == ["manifest.json", "summary.json", "trajectories.parquet"]


def _full_disk(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def _half_then_full(tmp, text: str = "half") -> None:
    """Half a file written to ``tmp``, then the disk is full."""
    from pathlib import Path

    Path(tmp).write_text(text)
    _full_disk()


@pytest.mark.parametrize("failing", ["trajectories.parquet", "summary.json", "view.html"])
def test_a_failed_write_leaves_no_half_set(tmp_path, monkeypatch, capsys, failing):
    import pyarrow.parquet as pq

    import crowdmotion.outputs
    import crowdmotion.render.player
    from crowdmotion.io.atomic import atomic_path

    path = _scenario(tmp_path)
    out = tmp_path / "out"
    if failing == "trajectories.parquet":
        monkeypatch.setattr(pq, "write_table", lambda table, where, **kw: _half_then_full(where))
    elif failing == "summary.json":
        real = crowdmotion.outputs.atomic_path

        @contextmanager
        def atomic_summary(target):
            with real(target) as tmp:
                if target.name == "summary.json":
                    _half_then_full(tmp)
                yield tmp

        monkeypatch.setattr(crowdmotion.outputs, "atomic_path", atomic_summary)
    else:
        def write_player(traj, dest, max_frames=3000):
            with atomic_path(dest) as tmp:
                _half_then_full(tmp, "<html>")

        monkeypatch.setattr(crowdmotion.render.player, "write_player", write_player)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths,player"]) == 2
    err = capsys.readouterr().err
    assert f"cannot write {out / failing}: No space left on device" in err, err
    assert "none of the run's files were kept" in err and ".tmp" not in err and "Traceback" not in err, err
    assert not out.exists() or _files(out) == []  # nothing: no pictures without trajectories, no temporary file
    monkeypatch.undo()
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths,player", "--overwrite"]) == 0
    assert _files(out) == ["manifest.json", "paths.png", "summary.json", "trajectories.parquet", "view.html"]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="pictures are drawn in a forked process on Linux")
def test_a_failed_write_leaves_no_temporary_file_of_a_picture_killed_mid_write(tmp_path, monkeypatch, capsys):
    # the picture process is stopped when the run's own write fails; one still writing a
    # picture past the polite signal's grace is killed outright, in the middle of its
    # atomic write: its temporary file must not stay behind in the user's folder
    import signal
    import time

    import crowdmotion._precompile
    import crowdmotion.outputs
    import crowdmotion.render.player
    from crowdmotion.io.atomic import atomic_path
    from crowdmotion.render.background import PictureProcess

    if crowdmotion._precompile.cores() < 2:
        pytest.skip("on one core the pictures are drawn in this process")
    path = _scenario(tmp_path)
    out = tmp_path / "out"
    real = crowdmotion.outputs.atomic_path
    real_start = PictureProcess.start.__func__
    started = []

    def start(cls):  # None where it cannot fork (another Python thread left running by an earlier test)
        started.append(real_start(cls))
        return started[-1]

    @contextmanager
    def atomic_summary(target):
        with real(target) as tmp:
            if target.name == "summary.json":
                if started[-1] is not None:  # fail once the picture process is inside its write of the player
                    for _ in range(3000):
                        if any(p.name.startswith(".view.html.") for p in target.parent.iterdir()):
                            break
                        time.sleep(0.01)
                    else:
                        pytest.fail("the player's atomic write never began")
                _half_then_full(tmp)
            yield tmp

    def stubborn_player(traj, dest, max_frames=3000):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # deaf to the polite signal: killed outright
        with atomic_path(dest) as tmp:
            tmp.write_text("<html>")
            time.sleep(60)

    monkeypatch.setattr(PictureProcess, "start", classmethod(start))
    monkeypatch.setattr(crowdmotion.outputs, "atomic_path", atomic_summary)
    monkeypatch.setattr(crowdmotion.render.player, "write_player", stubborn_player)
    monkeypatch.setattr(crowdmotion._precompile, "STOP_GRACE_S", 0.3)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "player"]) == 2
    assert "none of the run's files were kept" in capsys.readouterr().err
    assert not out.exists() or _files(out) == []
    if started[-1] is None:
        pytest.skip("no picture process could be forked here: the pictures were never begun")


def test_a_run_killed_while_writing_is_cleared_by_the_next_overwrite(tmp_path, capsys):
    path = _scenario(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths"]) == 0
    # as a run killed outright (SIGKILL, power cut) leaves it: its manifest says it did not finish
    manifest = json.loads((out / "manifest.json").read_text())
    (out / "manifest.json").write_text(json.dumps({**manifest, "complete": False}))
    (out / "paths.png").unlink()
    (out / ".paths.png.abcd1234.tmp").write_bytes(b"half")
    capsys.readouterr()
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 2
    assert "holds an earlier run that did not finish writing" in capsys.readouterr().err
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none", "--overwrite"]) == 0
    assert _files(out) == ["manifest.json", "summary.json", "trajectories.parquet"]


@pytest.mark.parametrize("where", ["here", "picture process"])
def test_a_picture_that_fails_to_draw_keeps_the_run_s_files(tmp_path, monkeypatch, capsys, where):
    # a bug in one picture must not throw away a simulation: its trajectories, summary and
    # the pictures that did draw are written whole and listed; the command says so and exits 1
    import json

    import crowdmotion._precompile
    import crowdmotion.render.player

    if where == "here":  # one core: the pictures drawn in this process
        monkeypatch.setattr(crowdmotion._precompile, "cores", lambda: 1)
    path = _scenario(tmp_path)
    out = tmp_path / "out"

    def broken_player(*args, **kwargs):
        raise KeyError("soldiers")

    monkeypatch.setattr(crowdmotion.render.player, "write_player", broken_player)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths,player"]) == 1
    err = capsys.readouterr().err
    assert "internal error drawing the pictures: KeyError: 'soldiers'" in err and "are kept" in err, err
    assert _files(out) == ["manifest.json", "paths.png", "summary.json", "trajectories.parquet"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] and sorted(manifest["files"]) == ["paths.png", "summary.json", "trajectories.parquet"]
