"""MDP output a character can play: steps that keep max_speed on diagonals, relaxed paths."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import mdp
from crowdmotion.mdp.simulation import run
from crowdmotion.metrics import collision_audit
from crowdmotion.path_relaxation import relax


def _diagonal_run(dim, **params):
    """One agent on an open floor (volume) whose goal lies on the grid's diagonal."""
    hi = [12.0] * dim
    scene = cm.Scene([[0.0] * dim, hi])
    group = cm.Group("a", 1, spawn=cm.Points([[0.5] * dim]), goal=cm.Points([[11.5] * dim]), radius=0.3,
                     pref_speed=1.0, max_speed=1.0)
    return run(scene, [group], mdp.MDPParams(smoothing=None, **params), np.random.default_rng(0))


@pytest.mark.parametrize("dim", [2, 3])
def test_diagonal_moves_never_exceed_max_speed(dim):
    res = _diagonal_run(dim)
    tr = res.trajectories
    cell = res.grid.cell_size
    steps = np.linalg.norm(np.diff(tr.positions[:, 0], axis=0), axis=-1)
    assert np.isclose(steps.max(), np.sqrt(dim) * cell)  # it does walk the diagonal
    # a diagonal of sqrt(dim) cells in one step of sqrt(dim) * cell / max_speed seconds
    assert tr.dt == pytest.approx(np.sqrt(dim) * cell / 1.0)
    assert tr.speed.max() <= 1.0 + 1e-9
    # the paper's time base (a cell per step at pref_speed) runs diagonals sqrt(dim) times faster
    paper = _diagonal_run(dim, speed_limited_steps=False).trajectories
    assert paper.dt == pytest.approx(cell)
    assert paper.speed.max() == pytest.approx(np.sqrt(dim))


def test_a_straight_uniform_walk_is_its_own_relaxation():
    t = np.arange(100)[:, None] / 24.0
    pos = np.concatenate([t * 1.2, 0.0 * t + 3.0], axis=1)[:, None, :]
    out = relax(pos, np.ones((100, 1), bool), np.array([0.3]), 1 / 24.0, None)
    np.testing.assert_allclose(out, pos, atol=1e-12)


def test_relaxing_a_zigzag_straightens_it_and_keeps_its_ends():
    # NE, SE, NE, SE ... one 0.8 m cell per 0.8 s step, sampled at 24 fps: a sawtooth of
    # amplitude 0.8 m about y = 0.4 (its mean line)
    steps = 40
    cells = np.stack([np.arange(steps + 1) * 0.8, (np.arange(steps + 1) % 2) * 0.8], axis=1)
    frames = np.concatenate([cells[k] + (cells[k + 1] - cells[k]) * (np.arange(19) / 19.2)[:, None]
                             for k in range(steps)] + [cells[-1:]])
    out = relax(frames[:, None, :], np.ones((len(frames), 1), bool), np.array([0.3]), 1 / 24.0, None)[:, 0]
    np.testing.assert_allclose(out[[0, -1]], frames[[0, -1]])
    middle = out[len(out) // 4: -len(out) // 4]
    assert np.abs(middle[:, 1] - 0.4).max() < 0.02  # within 2 cm of the mean line (was 40 cm off)


def test_relaxed_bodies_keep_apart_and_out_of_obstacles():
    # two agents pass each other 0.65 m apart (radius 0.3) on zigzags round a pillar
    scene = cm.Scene([[0.0, 0.0], [20.0, 10.0]], [cm.Circle([10.0, 5.0], 1.0)])
    groups = [cm.Group("east", 6, spawn=cm.Rect([1.0, 3.0], [3.0, 7.0]), goal=cm.Rect([17.0, 3.0], [19.0, 7.0]),
                       radius=0.3),
              cm.Group("west", 6, spawn=cm.Rect([17.0, 3.0], [19.0, 7.0]), goal=cm.Rect([1.0, 3.0], [3.0, 7.0]),
                       radius=0.3)]
    res = run(scene, groups, mdp.MDPParams(remove_on_arrival=True), np.random.default_rng(1))
    tr = res.trajectories
    assert tr.dt == pytest.approx(1 / 24)
    assert collision_audit(tr, scene).clean
    assert np.nanmax(tr.speed[:-1][tr.active_mask[:-1] & tr.active_mask[1:]]) <= 1.5 + 1e-9


def test_bodies_clear_at_their_frames_are_kept_apart_along_the_moves_between_them():
    # two bodies of radius 0.25 swap sides 0.3 m apart: 1.04 m apart at both frames, but the
    # straight moves between them meet (the audit sees 0.3 m at half the interval)
    from crowdmotion.path_relaxation import separate_swept
    from crowdmotion.trajectories import Trajectories

    X = np.array([[[0.0, 0.0], [1.0, 0.3]], [[1.0, 0.0], [0.0, 0.3]]])
    radius = np.full(2, 0.25)
    active = np.ones((2, 2), dtype=bool)
    assert not collision_audit(Trajectories(X.copy(), 0.5, radius=radius), None).clean
    separate_swept(X, active, radius, 0.01, 0.51, 50)
    assert collision_audit(Trajectories(X, 0.5, radius=radius), None).clean
    assert np.allclose(X.mean(axis=1), [[0.5, 0.15], [0.5, 0.15]])  # pushed apart, not moved on


def test_a_run_relaxed_at_its_own_steps_keeps_every_step_smooth(monkeypatch):
    # a run too large for fps (RELAX_AT_FPS_MAX) is relaxed at its steps: bodies kept apart
    # along the moves too, so that no step falls back to the plan's straight zig-zag
    from crowdmotion import path_relaxation
    from crowdmotion.metrics import root_motion

    monkeypatch.setattr(path_relaxation, "RELAX_AT_FPS_MAX", 1000)
    scene = cm.Scene([[0.0, 0.0], [20.0, 10.0]], [cm.Circle([10.0, 5.0], 1.0)])
    groups = [cm.Group("east", 12, spawn=cm.Rect([1.0, 2.0], [4.0, 8.0]), goal=cm.Rect([16.0, 2.0], [19.0, 8.0]),
                       radius=0.3),
              cm.Group("west", 12, spawn=cm.Rect([16.0, 2.0], [19.0, 8.0]), goal=cm.Rect([1.0, 2.0], [4.0, 8.0]),
                       radius=0.3)]
    tr = run(scene, groups, mdp.MDPParams(remove_on_arrival=True), np.random.default_rng(1)).trajectories
    assert tr.metadata["relaxed"]["at"] == "steps"
    assert tr.metadata["resampled"]["straight_segments"] == 0
    assert collision_audit(tr, scene).clean
    ok = tr.active_mask[:-1] & tr.active_mask[1:]
    assert np.nanmax(tr.speed[:-1][ok]) <= 1.5 + 1e-9
    rm = root_motion(tr)
    assert rm["acceleration_mps2"]["p95"] <= 2.0 and rm["deviation_from_1s_average_m"]["p95"] <= 0.05, rm


def test_a_crowd_queueing_at_a_door_keeps_its_relaxed_paths():
    # 80 people pressed in a queue before a 1 m door: the relaxed paths settle and keep
    # within each walker's speed, so that no step needs the plan's straight move; putting
    # steps back one by one brought the bodies beside them together in turn, until every
    # step was straight and the walkers turned and stopped as the plan does
    from crowdmotion.metrics import root_motion

    scene = cm.Scene([[0.0, 0.0], [14.0, 8.0]], [cm.Box([10.0, 0.0], [10.5, 3.5]), cm.Box([10.0, 4.5], [10.5, 8.0])])
    room = cm.Group("room", 80, spawn=cm.Rect([0.5, 0.5], [9.5, 7.5]), goal=cm.Rect([12.0, 1.0], [13.5, 7.0]),
                    radius=0.22)
    tr = run(scene, [room], mdp.MDPParams(remove_on_arrival=True), np.random.default_rng(0)).trajectories
    assert tr.metadata["relaxed"]["at"] == "fps"
    assert tr.metadata["resampled"]["straight_segments"] < 0.01 * tr.metadata["resampled"]["segments"]
    assert collision_audit(tr, scene).clean
    ok = tr.active_mask[:-1] & tr.active_mask[1:]
    assert np.nanmax(tr.speed[:-1][ok]) <= 1.5 + 1e-9
    rm = root_motion(tr)
    assert rm["acceleration_mps2"]["p95"] <= 2.0 and rm["deviation_from_1s_average_m"]["p95"] <= 0.05, rm


@pytest.mark.parametrize("value", [float("nan"), -1.0, 0.0])
def test_smoothing_window_must_be_a_positive_number_of_seconds(value):
    with pytest.raises(ValueError, match="smoothing_window"):
        mdp.MDPParams(smoothing_window=value)


def test_the_summary_says_how_the_paths_were_smoothed():
    from crowdmotion.mdp.adapter import run_scenario

    scene = cm.Scene([[0.0, 0.0], [20.0, 10.0]])
    groups = [cm.Group("a", 4, spawn=cm.Rect([1.0, 3.0], [3.0, 7.0]), goal=cm.Rect([17.0, 3.0], [19.0, 7.0]),
                       radius=0.3)]
    _, _, summary = run_scenario(scene, groups, mdp.MDPParams(remove_on_arrival=True), np.random.default_rng(0),
                                 progress=False)
    s = summary["smoothing"]
    assert s["kind"] == "relaxed" and s["window_s"] == 1.0 and s["at"] == "fps"
    assert s["straight_segments"] == 0 and s["segments"] > 0  # an open floor: every step relaxed
    _, _, plain = run_scenario(scene, groups, mdp.MDPParams(remove_on_arrival=True, smoothing=None),
                               np.random.default_rng(0), progress=False)
    assert plain["smoothing"] == {"kind": "none"}


def test_relaxed_paths_keep_bodies_inside_the_scene():
    # two walkers side by side along the scene's edge, closer than their bodies: pushed
    # apart, the one by the edge went past it (a body outside the scene, which the audit
    # did not count either)
    t = np.linspace(0.0, 4.0, 97)[:, None]
    walk = np.stack([np.hstack([1 + t, 0 * t + 0.3]), np.hstack([1 + t, 0 * t + 0.6])], axis=1)
    scene = cm.Scene([[0, 0], [8, 5]])
    out = relax(walk, np.ones((97, 2), bool), np.array([0.25, 0.25]), 1 / 24, scene)
    assert out[:, 0, 1].min() >= 0.25 - 1e-9 and np.abs(out[:, 1, 1] - out[:, 0, 1]).min() >= 0.5 - 1e-6
    assert collision_audit(cm.Trajectories(out, 1 / 24, radius=0.25), scene).clean
    assert not collision_audit(cm.Trajectories(walk, 1 / 24, radius=0.25), scene).clean  # as given, they touch
