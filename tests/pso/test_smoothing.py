"""Smooth root motion: the swarm's paths relaxed at the output frame rate
(``PSOParams.smoothing = "relaxed"``, the default) turn and accelerate as a flying or
walking group would, stay within max_speed and keep the collision guarantee."""

import numpy as np
import pytest

from crowdmotion import Circle, Scene, metrics, pso
from crowdmotion.groups import Group, Points, Rect
from crowdmotion.path_relaxation import limit_steps
from crowdmotion.pso import PSOParams
from crowdmotion.pso.swarm import RELAX_MARGIN

FPS = 24.0


def _two_swarms(smoothing: str):
    """Two 12-particle swarms swap sides of a 2D yard round a pillar (seed 4)."""
    scene = Scene(bounds=([-20.0, -12.0], [20.0, 12.0]), obstacles=[Circle([0.0, 1.0], 2.5)])
    groups = [Group(name="west", count=12, radius=0.3, max_speed=2.9, spawn=Rect([-18.0, -8.0], [-12.0, 8.0]),
                    goal=Points([[14.0, 1.0]])),
              Group(name="east", count=12, radius=0.3, max_speed=2.9, spawn=Rect([12.0, -8.0], [18.0, 8.0]),
                    goal=Points([[-14.0, -1.0]]))]
    params = PSOParams(iterations=200, smoothing=smoothing, fps=FPS)
    return pso.run(scene, groups, params, np.random.default_rng(4)), groups


@pytest.fixture(scope="module")
def crossing():
    return {kind: _two_swarms(kind) for kind in ("relaxed", "linear")}


def test_a_swarm_turns_no_faster_than_2_rad_s_and_accelerates_no_more_than_2_m_s2_at_24_fps(crossing):
    run, _ = crossing["relaxed"]
    rm = metrics.root_motion(run.trajectories)
    assert rm["acceleration_mps2"]["p95"] <= 2.0, rm
    assert rm["turn_rate_rad_s"]["p95"] <= 2.0, rm
    assert rm["deviation_from_1s_average_m"]["p95"] <= 0.08, rm
    # the paper's iterates, straight between them, jerk at every iteration (a fresh velocity each)
    straight = metrics.root_motion(crossing["linear"][0].trajectories)
    assert straight["acceleration_mps2"]["p95"] > 10 * rm["acceleration_mps2"]["p95"], straight
    assert straight["turn_rate_rad_s"]["p95"] > 5 * rm["turn_rate_rad_s"]["p95"], straight


def test_relaxed_paths_keep_apart_out_of_obstacles_and_within_max_speed(crossing):
    run, groups = crossing["relaxed"]
    traj = run.trajectories
    audit = metrics.collision_audit(traj, run.scene)
    assert (audit.agent_agent, audit.agent_obstacle) == (0, 0), audit.events[:3]
    assert traj.dt == pytest.approx(1 / FPS)
    assert traj.speed[:-1].max() <= 2.9 + 1e-9
    assert traj.metadata["resampled"]["kind"] == "relaxed"


def test_relaxing_keeps_the_run_its_starts_its_ends_and_its_timing(crossing):
    run, _ = crossing["relaxed"]
    linear = crossing["linear"][0]
    np.testing.assert_array_equal(run.swarm_run.paths, linear.swarm_run.paths)  # the swarm itself is the paper's
    assert run.swarm_run.arrival_rate == 1.0
    a, b = run.trajectories, linear.trajectories
    assert a.positions.shape == b.positions.shape
    np.testing.assert_allclose(a.positions[0], b.positions[0])
    # the ends stay, but for the pushes that keep bodies RELAX_MARGIN apart (the gathered swarm packs closer)
    assert np.abs(a.positions[-1] - b.positions[-1]).max() <= 2 * RELAX_MARGIN


def test_a_gathering_swarm_in_3d_turns_and_accelerates_gently_too():
    run = pso.gather(n_particles=20, rng=np.random.default_rng(2))
    rough = metrics.root_motion(run.trajectories(fps=FPS, smoothing="linear"))
    traj = run.trajectories(fps=FPS)  # params.smoothing: relaxed
    rm = metrics.root_motion(traj)
    assert rm["acceleration_mps2"]["p95"] <= 2.0 and rm["turn_rate_rad_s"]["p95"] <= 2.0, rm
    assert rough["acceleration_mps2"]["p95"] > 10.0, rough
    audit = metrics.collision_audit(traj, run.scene)
    assert (audit.agent_agent, audit.agent_obstacle) == (0, 0)
    # without a max_speed, no particle goes faster than its own fastest iterate
    fastest = np.linalg.norm(np.diff(run.paths, axis=0), axis=-1).max() / run.iteration_time
    assert traj.speed[:-1].max() <= fastest + 1e-9


def test_linear_smoothing_is_the_iterates_played_straight():
    run = pso.gather(n_particles=10, rng=np.random.default_rng(1), smoothing="linear")
    traj = run.trajectories(fps=4.0)  # one frame per 0.25 s iteration: the iterates themselves
    np.testing.assert_allclose(traj.positions, run.paths)


def test_the_summary_says_how_the_paths_were_smoothed():
    from crowdmotion.pso.adapter import run_scenario

    scene = Scene(bounds=([-15.0, -15.0], [15.0, 15.0]))
    groups = [Group(name="g", count=8, radius=0.25, max_speed=3.0, spawn=Rect([-12.0, -12.0], [-6.0, -6.0]),
                    goal=Points([[8.0, 8.0]]))]
    params = PSOParams(v_max=[0.5], smoothing_window=1.0)
    _, _, s = run_scenario(scene, groups, params, np.random.default_rng(0), progress=False)
    assert s["smoothing"]["kind"] == "relaxed" and s["smoothing"]["window_s"] == 1.0
    assert s["smoothing"]["straight_segments"] == 0 and s["smoothing"]["segments"] > 0
    assert s["root_motion"]["acceleration_mps2"]["p95"] <= 2.0
    _, _, s = run_scenario(scene, groups, params.model_copy(update={"smoothing": "linear"}),
                           np.random.default_rng(0), progress=False)
    assert s["smoothing"] == {"kind": "linear"}


@pytest.mark.parametrize("field, value", [("smoothing", "spline"), ("smoothing", None), ("smoothing_window", 0.0),
                                          ("smoothing_window", -1.0), ("smoothing_window", float("nan"))])
def test_bad_smoothing_params_are_refused_naming_the_field(field, value):
    with pytest.raises(ValueError, match=f"pso.{field}"):
        pso.make_params(**{field: value})


def test_limit_steps_shortens_only_the_steps_that_outrun_and_keeps_the_ends():
    # one agent: steps of 1, 3, 1, 1 m; at most 2 m a step
    x = np.array([[0.0], [1.0], [4.0], [5.0], [6.0]])[:, None, :].repeat(2, axis=1)
    x[:, 1] *= 0.5  # a second agent, slow enough already
    before = x.copy()
    n = limit_steps(x, np.array([0, 0]), np.array([4, 4]), np.array([2.0, 2.0]), 50)
    steps = np.abs(np.diff(x[:, :, 0], axis=0))
    assert n > 0 and steps.max() <= 2.0 + 1e-9
    np.testing.assert_array_equal(x[[0, -1]], before[[0, -1]])  # ends stay
    np.testing.assert_array_equal(x[:, 1], before[:, 1])  # nothing to do for the slow one
