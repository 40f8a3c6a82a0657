"""JuPedSim SQLite files: our round trip, and PedPy reading them."""

import pathlib
import sqlite3

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.scene import Box, Circle, Scene
from tests.io.test_roundtrip import sample


def _scene_run():
    scene = Scene(((0, 0), (20, 10)), [Circle((10, 5), 1.0), Box((3, 6), (4, 9))])
    t = np.arange(40) * 0.1
    pos = np.stack([np.stack([1 + t * 0.4 + k, 2 + 0.5 * k + 0 * t], axis=1) for k in range(5)], axis=1)
    return Trajectories(pos, 0.1, group=np.array(["g"] * 5, object), radius=[0.25] * 5,
                        metadata={"scene": scene.to_dict(), "method": "rvo"}), scene


def test_roundtrip_keeps_positions_timing_groups_and_gaps(tmp_path):
    tr = sample(2)
    back = Trajectories.load(tr.save(tmp_path / "t.sqlite"))
    # positions carry a fixed jitter of at most 1 µm (for PedPy's Voronoi)
    np.testing.assert_allclose(back.positions[tr.active_mask], tr.positions[tr.active_mask], rtol=0, atol=1e-6)
    assert back.dt == pytest.approx(0.25)
    np.testing.assert_array_equal(back.active, tr.active)
    assert back.group.tolist() == tr.group.tolist() and back.radius.tolist() == pytest.approx(tr.radius.tolist())
    assert back.metadata["seed"] == 3


def test_the_file_follows_the_jupedsim_v2_schema(tmp_path):
    tr, scene = _scene_run()
    path = tr.save(tmp_path / "run.sqlite")
    con = sqlite3.connect(path)
    meta = dict(con.execute("SELECT key, value FROM metadata").fetchall())
    cols = [r[1] for r in con.execute("PRAGMA table_info(trajectory_data)")]
    (wkt,) = con.execute("SELECT wkt FROM geometry").fetchone()
    n_frames = con.execute("SELECT COUNT(*) FROM frame_data").fetchone()[0]
    ori = np.array(con.execute("SELECT ori_x, ori_y FROM trajectory_data").fetchall())
    con.close()
    assert cols == ["frame", "id", "pos_x", "pos_y", "ori_x", "ori_y"]
    assert meta["version"] == "2" and float(meta["fps"]) == pytest.approx(10.0)
    assert (float(meta["xmin"]), float(meta["ymax"])) == (0.0, 10.0)
    assert n_frames == 40 and wkt.startswith("POLYGON")
    np.testing.assert_allclose(ori, np.tile([1.0, 0.0], (len(ori), 1)), atol=1e-12)  # all walk along +x


def test_pedpy_reads_it_and_computes_a_density_profile(tmp_path):
    pedpy = pytest.importorskip("pedpy")
    tr, scene = _scene_run()
    path = pathlib.Path(tr.save(tmp_path / "run.sqlite"))
    data = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=path)
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=path)
    assert data.frame_rate == pytest.approx(10.0) and len(data.data) == 40 * 5
    # the walkable area is the bounds less the circle and the box
    assert area.polygon.area == pytest.approx(200 - np.pi - 3, rel=1e-3)
    profiles = pedpy.compute_density_profile(data=data.data, walkable_area=area, grid_size=1.0,
                                             density_method=pedpy.DensityMethod.CLASSIC)
    assert len(profiles) == 40
    # classic density: 5 agents in 1 m² cells, frame by frame
    assert sum(float(np.nansum(p)) for p in profiles) == pytest.approx(40 * 5, rel=1e-6)


def test_3d_runs_are_projected_and_say_so(tmp_path):
    from crowdmotion.io import write_trajectories

    with pytest.warns(UserWarning, match="projected onto the ground plane") as caught:
        write_trajectories(sample(3), tmp_path / "direct.sqlite")
        path = sample(3).save(tmp_path / "t.sqlite")
    assert [w.filename for w in caught] == [__file__, __file__]  # the caller's line, not ours
    back = Trajectories.load(path)
    assert back.dim == 2
    np.testing.assert_allclose(back.positions[sample(3).active_mask], sample(3).positions[..., :2][sample(3).active_mask],
                               rtol=0, atol=1e-6)


def test_a_corrupt_file_is_refused(tmp_path):
    (tmp_path / "bad.sqlite").write_bytes(b"not a database at all" * 10)
    with pytest.raises(ValueError, match="not a JuPedSim trajectory SQLite"):
        Trajectories.load(tmp_path / "bad.sqlite")


def test_every_frame_comes_back_after_the_last_agent_has_left(tmp_path):
    # issue 17: an MDP SQLite with despawned agents loaded back 68 of 151 frames
    pos = np.cumsum(np.full((10, 2, 2), 0.3), axis=0)
    pos[:, 1, 1] += 2
    act = np.ones((10, 2), bool)
    act[4:, 0] = False
    act[6:, 1] = False  # nobody active after frame 5
    tr = Trajectories(pos, 0.5, active=act)
    back = Trajectories.load(tr.save(tmp_path / "t.sqlite"))
    assert back.n_frames == 10
    np.testing.assert_array_equal(back.active_mask, act)


def test_the_walkable_area_is_the_one_piece_the_agents_use(tmp_path):
    # issue 17: a wall cutting off a pocket made a MULTIPOLYGON that PedPy and JuPedSim refuse
    pedpy = pytest.importorskip("pedpy")
    scene = Scene(((0, 0), (20, 10)), [Box((8, 0), (9, 10)), Circle((14, 5), 1.0)])  # a wall from side to side
    pos = np.stack([np.linspace(10, 18, 30), np.full(30, 2.0)], axis=1)[:, None, :]
    tr = Trajectories(pos, 0.1, radius=[0.25], metadata={"scene": scene.to_dict()})
    path = pathlib.Path(tr.save(tmp_path / "pocket.sqlite"))
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=path)
    assert area.polygon.bounds == (9.0, 0.0, 20.0, 10.0)  # the right-hand room, less the circle
    assert area.polygon.area == pytest.approx(11 * 10 - np.pi, rel=1e-3)
    # an agent in the other room is named, not silently dropped
    left = np.stack([np.linspace(1, 7, 30), np.full(30, 2.0)], axis=1)[:, None, :]
    both = Trajectories(np.concatenate([pos, left], axis=1), 0.1, radius=[0.25, 0.25],
                        metadata={"scene": scene.to_dict()})
    with pytest.warns(UserWarning, match="30 of 60 agent positions lie outside the walkable area"):
        both.save(tmp_path / "two_rooms.sqlite")


def test_3d_obstacles_flown_over_stay_walkable_and_stacked_drones_get_a_voronoi(tmp_path):
    pedpy = pytest.importorskip("pedpy")
    from crowdmotion.scene import Sphere

    scene = Scene(((0, 0, 0), (10, 10, 10)), [Box((4, 4, 0), (6, 6, 3)), Sphere((8, 8, 8), 0.5)])
    t = np.linspace(0, 1, 11)
    # two drones stacked in z fly over the box; a third keeps away from both obstacles
    a = np.stack([1 + 8 * t, np.full(11, 5.0), np.full(11, 4.0)], axis=1)
    pos = np.stack([a, a + [0, 0, 2.0], np.stack([np.full(11, 1.0), 1 + 2 * t, np.full(11, 2.0)], axis=1)], axis=1)
    tr = Trajectories(pos, 0.1, radius=[0.3] * 3, metadata={"scene": scene.to_dict()})
    with pytest.warns(UserWarning, match="projected"):
        path = pathlib.Path(tr.save(tmp_path / "drones.sqlite"))
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=path)
    assert area.polygon.area == pytest.approx(100 - np.pi * 0.25, rel=1e-3)  # the box is flown over
    data = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=path)
    voronoi = pedpy.compute_individual_voronoi_polygons(traj_data=data, walkable_area=area)
    assert len(voronoi) == 33 and np.isfinite(voronoi["density"]).all()


def test_pedpy_voronoi_runs_on_an_exact_lattice(tmp_path):
    # issue 17: GEOS's Voronoi fails on agents standing on an exact lattice (MDP cells)
    pedpy = pytest.importorskip("pedpy")
    cell = 0.8494
    gx, gy = np.meshgrid(np.arange(6), np.arange(5))
    lattice = np.stack([gx.ravel(), gy.ravel()], axis=1) * cell + 1.0
    pos = np.repeat(lattice[None], 4, axis=0)
    scene = Scene(((0, 0), (8, 6)), [Circle((7, 5), 0.5)])
    tr = Trajectories(pos, 0.5, radius=[0.25] * len(lattice), metadata={"scene": scene.to_dict()})
    path = pathlib.Path(tr.save(tmp_path / "lattice.sqlite"))
    data = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=path)
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=path)
    voronoi = pedpy.compute_individual_voronoi_polygons(traj_data=data, walkable_area=area)
    assert len(voronoi) == 4 * 30
    # inner cells are the lattice's squares
    assert voronoi["density"].max() == pytest.approx(1 / cell ** 2, rel=1e-4)
