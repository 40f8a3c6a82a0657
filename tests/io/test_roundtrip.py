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


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_a_games_frame_rate_reads_back_exactly(tmp_path, suffix):
    # 3601 frames at 1/60 s: the times column rounds (0.01666666666666572 from its
    # differences); the step the file was written with comes back as it was
    tr = Trajectories(np.zeros((3601, 1, 2)), 1 / 60)
    assert Trajectories.load(tr.save(tmp_path / f"t.{suffix}")).dt == 1 / 60


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


def test_tables_are_typed_for_any_reader_and_say_rate_units_and_axes(tmp_path):
    # issue 17: a 2D CSV wrote an empty z that polars/DuckDB read as text; no fps in the metadata
    import csv
    import json

    import pyarrow.parquet as pq

    pos = np.cumsum(np.full((5, 2, 2), 0.5), axis=0)
    tr = Trajectories(pos, 0.25)
    with open(tr.save(tmp_path / "t.csv")) as f:
        header = next(csv.reader(f))
    assert "z" not in header
    meta = json.loads((tmp_path / "t.csv.meta.json").read_text())
    assert meta["fps"] == 4.0 and meta["dim"] == 2 and meta["units"]["length"] == "m" and "axes" in meta
    table = pq.read_table(tr.save(tmp_path / "t.parquet"))
    assert "z" not in table.column_names
    assert all(str(t) in ("int64", "double", "float", "string", "bool") for t in table.schema.types)
    assert Trajectories.load(tmp_path / "t.parquet").dim == 2


@pytest.mark.parametrize("suffix", ["parquet", "csv"])
def test_nan_positions_of_an_active_agent_are_refused_on_save_and_on_load_naming_the_file(
        tmp_path, suffix):
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from crowdmotion.io.longform import to_table
    from crowdmotion.locomotion import locomotion

    tr = sample()
    tr.positions[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"positions of agent 1 at frame 2 is not finite: nan$"):
        tr.save(tmp_path / f"refused.{suffix}")  # the writer refuses it ...
    assert not (tmp_path / f"refused.{suffix}").exists()
    path = tmp_path / f"t.{suffix}"  # ... so a damaged file is made by hand
    (pq.write_table if suffix == "parquet" else pacsv.write_csv)(to_table(tr, locomotion(sample())), path)
    with pytest.raises(ValueError, match=rf"^{path}: positions of agent 1 at frame 2 is not finite: nan$"):
        Trajectories.load(path)
    tr = sample()
    tr.positions[5, 1] = np.nan  # agent 1 has left by frame 4: where it stands then is no one's business
    assert np.isnan(Trajectories.load(tr.save(tmp_path / f"gone.{suffix}")).positions[5, 1]).all()


def test_a_trajectories_file_without_frames_or_with_a_bad_radius_is_refused_naming_the_file(tmp_path):
    import pyarrow.parquet as pq

    from crowdmotion.io.longform import to_table

    empty = tmp_path / "empty.parquet"
    pq.write_table(to_table(sample()).slice(0, 0), empty)
    with pytest.raises(ValueError, match=rf"^{empty}: the trajectory file has no frames"):
        Trajectories.load(empty)
    for radius, words in (([0.2, -0.3, 0.2, 0.3], "radius of agent 1 is -0.3"),
                          ([0.2, 0.3, 0.0, 0.3], "radius of agent 2 is 0.0"),
                          ([0.2, 0.3, 0.2, np.nan], "radius of agent 3 is nan")):
        tr = sample()
        tr.radius = np.array(radius)
        path = tr.save(tmp_path / "r.csv")
        with pytest.raises(ValueError, match=rf"^{path}: {words}"):
            Trajectories.load(path)
    no_radii = Trajectories(sample().positions, 0.25)  # every radius 0: the file gives none
    assert (Trajectories.load(no_radii.save(tmp_path / "points.parquet")).radius == 0).all()


@pytest.mark.parametrize("suffix", ["parquet", "csv", "sqlite", "usda", "usdc"])
def test_every_format_round_trips_the_locomotion_channels(tmp_path, suffix):
    import warnings

    from crowdmotion.io import read_locomotion
    from crowdmotion.locomotion import locomotion

    if suffix.startswith("usd"):
        pytest.importorskip("pxr")
    t = np.arange(73) / 24
    pos = np.zeros((73, 3, 2))
    pos[:, 0, 0] = 1.3 * t  # walks
    pos[:, 1, 0] = 2.8 * t  # runs
    pos[:, 2, 1] = np.minimum(t, 1.5) * 6.0  # a car that stops
    active = np.ones((73, 3), bool)
    active[60:, 0] = False  # the walker leaves
    tr = Trajectories(pos, 1 / 24, group=np.array(["a", "a", "cars"], object), radius=[0.25, 0.25, 0.9],
                      active=active, metadata={"bodies": {"cars": "car"}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SQLite: agents outside the walkable area
        back = read_locomotion(tr.save(tmp_path / f"t.{suffix}"))
    want = locomotion(tr)
    tol = 1e-9 if suffix == "sqlite" else 1e-5  # the others store single precision
    assert back.kind.tolist() == ["walker", "walker", "car"]
    for name in ("distance", "gait_phase", "turn_rate"):
        np.testing.assert_allclose(getattr(back, name)[active], getattr(want, name)[active], atol=tol, err_msg=name)
    for name in ("gait_state", "contact_left", "contact_right"):
        np.testing.assert_array_equal(getattr(back, name)[active], getattr(want, name)[active], err_msg=name)
    assert np.isnan(back.gait_phase[:, 2]).all()


def test_an_export_at_another_rate_carries_channels_of_the_frames_it_writes(tmp_path):
    from crowdmotion.cli import main
    from crowdmotion.io import read_locomotion
    from crowdmotion.locomotion import locomotion

    t = np.arange(21) * 0.25  # a 4 fps run, as RVO steps
    pos = np.zeros((21, 2, 2))
    pos[:, 0, 0] = 1.0 * t
    pos[:, 1, 0] = 2.0 * t
    src = Trajectories(pos, 0.25).save(tmp_path / "run.parquet")
    assert main(["export", str(src), "--to", "parquet", "--fps", "24", "-o", str(tmp_path / "at24.parquet")]) == 0
    written = Trajectories.load(tmp_path / "at24.parquet")
    loco = read_locomotion(tmp_path / "at24.parquet")
    assert written.n_frames == loco.gait_phase.shape[0] == 121
    np.testing.assert_allclose(loco.gait_phase, locomotion(written).gait_phase, atol=1e-6)
