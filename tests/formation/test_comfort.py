"""Comfortable motion: soldiers of a formation walk without twitching, because
the guiding mesh changes velocity no faster than a walker does and leaves room for the
agents' bodies; the collision guarantee and the recovery are kept."""

import numpy as np
import pytest

from crowdmotion import Scene, formation, metrics
from crowdmotion.formation.comfort import clip_rows, limit_acceleration, spread_vertices, stopping_speed
from crowdmotion.groups import Group, Points
from crowdmotion.scene import Box, Circle

OFF = {"mesh_acceleration": 0.0, "vertex_gap": 0.0}  # the paper's kinematic mesh


def _rocks_and_gate():
    """A 6 x 6 block (7.2 m wide) through three rocks, then a 5 m gate: it widens, then
    must compress to pass."""
    scene = Scene(((0, -12), (60, 12)), [Circle((16, -1.5), 0.5), Circle((18, 2.0), 0.6), Circle((20, -3.0), 0.5),
                                         Box((30, -12), (31.5, -2.5)), Box((30, 2.5), (31.5, 12))])
    groups = [Group("army", 36, Points([[5.0, 0.0]]), (50.0, 0.0), radius=0.3, pref_speed=1.3, max_speed=1.5,
                    attributes={"formation": {"kind": "block", "rows": 6, "cols": 6, "spacing": 1.2}})]
    return scene, groups


@pytest.fixture(scope="module")
def runs():
    scene, groups = _rocks_and_gate()
    out = {}
    for name, over in (("comfortable", {}), ("paper", OFF)):
        out[name] = formation.run(scene, groups, {"max_steps": 1500, **over}, np.random.default_rng(0))
    return scene, out


def test_soldiers_of_a_block_walk_without_twitching_acceleration_p95_within_2_mps2_at_24_fps(runs):
    scene, out = runs
    run = out["comfortable"]
    traj = run.trajectories
    assert traj.dt == pytest.approx(1 / 24)
    rm = metrics.root_motion(traj)
    assert rm["acceleration_mps2"]["p95"] <= 2.0, rm
    assert rm["turn_rate_rad_s"]["p95"] <= 2.0, rm
    assert rm["deviation_from_1s_average_m"]["p95"] <= 0.05, rm
    assert np.nanmax(traj.speed) <= 1.5 + 1e-9
    assert metrics.collision_audit(traj, scene).clean
    g = run.report["army"]
    assert g["recovered_s"] is not None and g["kabsch_rms_m"] < 0.01  # ends standing in its shape


def test_the_papers_kinematic_mesh_twitches_in_the_same_scene(runs):
    # the term is what makes the difference: switched off, the same block twitches
    scene, out = runs
    rm = metrics.root_motion(out["paper"].trajectories)
    assert rm["acceleration_mps2"]["p95"] > 2.0 and rm["acceleration_mps2"]["max"] > 10.0, rm
    assert metrics.collision_audit(out["paper"].trajectories, scene).clean


def test_the_mesh_changes_velocity_no_faster_than_mesh_acceleration(runs):
    # in the open (before the rocks' fields and after the gate's) only the limit acts on a
    # vertex; the pushes out of walls and apart come after it and may add to it
    scene, out = runs
    run = out["comfortable"]
    V = run.vertices[0]
    dt = run.simulator.dt
    a = np.linalg.norm(V[2:] - 2 * V[1:-1] + V[:-2], axis=-1) / dt**2
    open_ = V[1:-1, :, 0].max(axis=1) < 13.0  # the front rank 1.5 m short of the first rock's field
    assert open_.sum() > 30
    assert a[open_].max() <= 0.8 + 1e-6
    assert a[~open_].max() > 0.8  # (where walls push, they may)


def test_a_block_compressed_by_a_gate_is_not_stopped_and_started_by_the_safety_pass(runs):
    # vertices nearer each other than the bodies pressed the agents together, and the
    # safety pass stopped one of every touching pair a step (stop and go)
    _, out = runs
    comfortable, paper = (out[k].simulator.stats["safety_stops"] for k in ("comfortable", "paper"))
    assert comfortable * 5 < paper, (comfortable, paper)
    V = out["comfortable"].vertices[0]
    from scipy.spatial import cKDTree

    nearest = min(cKDTree(v).query(v, k=2)[0][:, 1].min() for v in V)
    assert nearest > 2 * 0.3  # the mesh always leaves room for two bodies side by side


def test_limit_acceleration_moves_toward_the_wish_by_at_most_a_dt():
    last = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 0.0]])
    want = np.array([[1.0, 0.05], [0.0, 1.0], [0.0, 0.0]])
    got = limit_acceleration(last, want, 1.0, 0.1)
    np.testing.assert_allclose(got[0], [1.0, 0.05])  # within reach: the wish
    np.testing.assert_allclose(got[1], [1.0 - 0.1 / np.sqrt(2), 0.1 / np.sqrt(2)])  # 0.1 along the change
    np.testing.assert_allclose(got[2], [0.0, 0.0])
    np.testing.assert_allclose(clip_rows(np.array([[3.0, 4.0], [0.3, 0.4]]), 1.0), [[0.6, 0.8], [0.3, 0.4]])


def test_a_vertex_braking_from_its_stopping_speed_stops_on_its_place():
    # v = sqrt(2 a d): braking at a from there covers v^2 / 2a = d
    a, d = 0.8, np.array([0.01, 0.5, 3.0])
    v = stopping_speed(d, a)
    np.testing.assert_allclose(v**2 / (2 * a), d)


def test_spread_vertices_parts_a_near_pair_to_the_distance_needed_and_leaves_others():
    V = np.array([[0.0, 0.0], [0.2, 0.0], [5.0, 5.0], [6.0, 5.0]])
    out = spread_vertices(V, 0.65)
    np.testing.assert_allclose(out[0], [-0.225, 0.0])  # each by half the shortfall of 0.45
    np.testing.assert_allclose(out[1], [0.425, 0.0])
    np.testing.assert_array_equal(out[2:], V[2:])
    # a cloud of 60 points in 8 m x 8 m (room for all): within three sweeps no two are
    # much nearer than needed (the nearest pair was 2 cm apart)
    rng = np.random.default_rng(3)
    cloud = rng.random((60, 2)) * 8.0
    from scipy.spatial import cKDTree

    spread = spread_vertices(cloud, 0.65)
    assert cKDTree(cloud).query(cloud, k=2)[0][:, 1].min() < 0.05
    assert cKDTree(spread).query(spread, k=2)[0][:, 1].min() > 0.9 * 0.65


def test_cars_keep_their_own_kinematics():
    # the traffic template's mesh is not limited: the term is for walkers
    scene = Scene(((0, -10), (120, 10)))
    sim = formation.Simulator(scene, time_step=0.05)
    sim.add_group({"kind": "cars", "lanes": 1, "per_lane": 2, "car_width": 1.8, "car_gap": 8.0}, goal=(100, 0),
                  start=(10, 0), pref_speed=4.0, max_speed=8.0, radius=0.3)
    sim.step()
    assert not sim.groups[0].comfortable(sim.params)
    assert np.linalg.norm(sim.groups[0].vertex_velocity, axis=1).min() > 3.0  # full speed in one step
