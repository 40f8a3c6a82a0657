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
