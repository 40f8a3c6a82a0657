"""Checks that a run's files open right in the programs users open them in (issue 17):
PedPy and JuPedSim for the SQLite, pxr for the USD. Used on every built-in scene."""

from __future__ import annotations

import pathlib
import warnings

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.scene import Scene

#: frames of a run whose Voronoi density PedPy computes (its time grows with the frames:
#: 22 s for a 5101-frame built-in on every frame)
VORONOI_FRAMES = 100


def assert_sqlite_opens_in_pedpy_and_jupedsim(traj: Trajectories, folder: pathlib.Path) -> None:
    """PedPy loads the trajectory and the walkable area and its Voronoi density runs on
    up to VORONOI_FRAMES frames spread over the run (the first and the last among them);
    JuPedSim's Recording reads it and its RoutingEngine takes the geometry."""
    pedpy = pytest.importorskip("pedpy")
    jps = pytest.importorskip("jupedsim")
    if traj.dim == 3:
        with pytest.warns(UserWarning, match="projected onto the ground plane"):
            path = pathlib.Path(traj.save(folder / "run.sqlite"))
    else:  # a 2D built-in's file needs no warning (no agent outside its walkable area)
        with warnings.catch_warnings():
            warnings.simplefilter("error", UserWarning)
            path = pathlib.Path(traj.save(folder / "run.sqlite"))
    data = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=path)
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=path)
    assert data.frame_rate == pytest.approx(traj.fps)
    assert len(data.data) == int(traj.active_mask.sum())
    frames = np.unique(data.data["frame"])
    frames = frames[np.unique(np.linspace(0, len(frames) - 1, min(len(frames), VORONOI_FRAMES)).astype(int))]
    some = pedpy.TrajectoryData(data=data.data[data.data["frame"].isin(frames)], frame_rate=data.frame_rate)
    voronoi = pedpy.compute_individual_voronoi_polygons(traj_data=some, walkable_area=area)
    assert len(voronoi) == len(some.data)
    assert np.isfinite(voronoi["density"]).all() and (voronoi["density"] > 0).all()
    recording = jps.Recording(str(path))
    assert recording.num_frames == traj.n_frames
    engine = jps.RoutingEngine(recording.geometry())
    assert engine.is_routable(tuple(data.data[["x", "y"]].iloc[0]))


def _scene_bound(ob, dim: int, t: float) -> tuple[np.ndarray, np.ndarray]:
    """World (lo, hi) of an obstacle at time t; 2D obstacles are written 2 m tall
    (a polygon as a prism)."""
    from crowdmotion.io.usd import OBSTACLE_HEIGHT

    lo, hi = (np.asarray(b, float) + ob.offset(t) for b in ob.bounds())
    if dim == 2:
        lo, hi = np.append(lo, 0.0), np.append(hi, OBSTACLE_HEIGHT)
    return lo, hi


def assert_usd_obstacles_where_the_scene_has_them(traj: Trajectories, folder: pathlib.Path) -> None:
    """pxr's world bound of every obstacle equals the scene's, at the first, middle and last
    frame (a moving obstacle along its path at f / fps)."""
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    from crowdmotion.io.usd import from_usd_frame, stage_rate

    scene = Scene.from_dict(traj.metadata["scene"])
    stage = Usd.Stage.Open(str(traj.save(folder / "run.usdc")))
    rate = stage_rate(traj)
    for f in sorted({0, traj.n_frames // 2, traj.n_frames - 1}):
        t = f * traj.dt
        cache = UsdGeom.BBoxCache(Usd.TimeCode(t * rate), ["default"])
        for k, ob in enumerate(scene.obstacles):
            box = cache.ComputeWorldBound(stage.GetPrimAtPath(f"/World/Obstacles/obstacle_{k}")).ComputeAlignedRange()
            corners = from_usd_frame(np.array([box.GetMin(), box.GetMax()]), 3)
            lo, hi = corners.min(axis=0), corners.max(axis=0)
            want_lo, want_hi = _scene_bound(ob, scene.dim, t)
            np.testing.assert_allclose(np.concatenate([lo, hi]), np.concatenate([want_lo, want_hi]), atol=2e-3,
                                       err_msg=f"obstacle {k} ({type(ob).__name__}) at frame {f}")


def door_session():
    """A live RVO session recorded at 10 steps a second: one walker, a wall that always
    stands (obstacle 0) and a door dropped in at 1 s and taken away at 2 s; returns the
    recorded trajectories and the door's obstacle index."""
    import crowdmotion as cm
    from crowdmotion import rvo

    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([5, 8], [6, 9])]), time_step=0.1)
    sim.add_agents([[2, 5]], [18, 5])
    rec = rvo.Recorder(sim)
    for step in range(30):
        if step == 10:
            door = sim.add_obstacle(cm.Box([16, 0.2], [17, 1.0]))
        if step == 20:
            sim.remove_obstacle(door)
        sim.step()
        rec.record()
    return rec.trajectories(), door
