"""Atomic writes: the file appears whole or not at all, with the usual permissions."""

import os
import stat

import pytest

from crowdmotion.io.atomic import atomic_path


def test_written_file_gets_the_umask_mode_and_a_failure_leaves_nothing(tmp_path):
    target = tmp_path / "out.txt"
    with atomic_path(target) as tmp:
        tmp.write_text("whole")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask
    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "half.txt") as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_an_interrupt_while_writing_leaves_the_old_file_and_no_temporary_one(tmp_path):
    target = tmp_path / "summary.json"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_text("new, half")
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"] and target.read_text() == "old"


def test_a_write_error_names_the_file_never_its_temporary_one(tmp_path):
    import errno

    from crowdmotion.io.atomic import WriteError

    target = tmp_path / "trajectories.parquet"
    with pytest.raises(OSError) as caught:
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
    assert isinstance(caught.value, WriteError) and caught.value.errno == errno.ENOSPC
    assert str(caught.value) == f"cannot write {target}: No space left on device"
    with pytest.raises(WriteError, match=r"cannot write .*paths\.png: .*broken pipe to "):
        with atomic_path(tmp_path / "paths.png") as tmp:
            raise OSError(f"broken pipe to {tmp}")  # a library's message holding the temporary name
    assert list(tmp_path.iterdir()) == []


def test_stale_temporary_files_are_told_from_other_files(tmp_path):
    from crowdmotion.io.atomic import remove_stale_temps

    stale = [".trajectories.parquet.a1b2c3d4.tmp", ".x.y.________.tmp", ".t.sqlite.abcdefgh.tmp-journal",
             ".trajectories.usdc.k9j8h7g6.usdc"]
    kept = ["keep.tmp", ".keep.tmp", ".a.toolong123.tmp", ".a.short.tmp", "a.b.abcdefgh.tmp", "data.parquet"]
    for name in stale + kept:
        (tmp_path / name).write_text("x")
    assert sorted(p.name for p in remove_stale_temps(tmp_path)) == sorted(stale)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept)
