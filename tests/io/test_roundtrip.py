"""Parquet and CSV round trips; failed writes leave nothing behind."""

import numpy as np
import pytest

from crowdmotion import Trajectories


def sample(dim=2):
    rng = np.random.default_rng(0)
    act = np.ones((6, 4), bool)
    act[4:, 1] = False
    return Trajectories(rng.normal(size=(6, 4, dim)), 0.25, group=np.array(["a", "a", "b", "b"], object),
                        radius=[0.2, 0.3, 0.2, 0.3], active=act, metadata={"method": "mdp", "seed": 3})


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
@pytest.mark.parametrize("dim", [2, 3])
def test_roundtrip(tmp_path, suffix, dim):
    tr = sample(dim)
    back = Trajectories.load(tr.save(tmp_path / f"t.{suffix}"))
    np.testing.assert_allclose(back.positions, tr.positions, rtol=1e-6)
    assert back.dt == pytest.approx(0.25)
    assert back.group.tolist() == tr.group.tolist()
    np.testing.assert_array_equal(back.active, tr.active)
    assert back.metadata["seed"] == 3


def test_unknown_format_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="unknown trajectory format"):
        sample().save(tmp_path / "t.xlsx")
    with pytest.raises(FileNotFoundError):
        Trajectories.load(tmp_path / "none.parquet")
    (tmp_path / "bad.parquet").write_bytes(b"not parquet")
    with pytest.raises(ValueError, match="not a readable Parquet"):
        Trajectories.load(tmp_path / "bad.parquet")


def test_failed_write_leaves_no_file(tmp_path, monkeypatch):
    import pyarrow.parquet as pq

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", boom)
    with pytest.raises(OSError):
        sample().save(tmp_path / "t.parquet")
    assert list(tmp_path.iterdir()) == []


def test_unwritable_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        sample().save(tmp_path / "missing" / "t.parquet")
