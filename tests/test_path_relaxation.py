"""Relaxing a simulated run's own steps (path_relaxation.relaxed_steps): smoother, same ends,
within max_speed, as clean as the steps; MDP's relaxation at fps is tested in tests/mdp."""

import warnings

import numpy as np
import pytest

from crowdmotion.path_relaxation import relaxed_steps, warn_if_straight
from crowdmotion.trajectories import Trajectories


def _stop_and_go(n_steps=40, dt=0.25):
    """One walker along x: 0.5 m in one step, none in the next (1 m/s on average)."""
    x = np.concatenate([[0.0], np.cumsum(np.where(np.arange(n_steps) % 2 == 0, 0.5, 0.0))])
    return np.stack([x, np.full_like(x, 2.0)], axis=1)[:, None, :], dt


def test_a_stop_and_go_walk_is_smoothed_keeping_its_ends_and_its_speed_limit():
    pos, dt = _stop_and_go()
    traj = Trajectories(pos, dt, radius=np.array([0.25]))
    out = relaxed_steps(traj, 1.0, None, np.array([2.0]))
    p = out.positions[:, 0]
    np.testing.assert_array_equal(p[[0, -1]], pos[[0, -1], 0])
    assert np.allclose(p[:, 1], 2.0)  # it stays on its line
    jerk = lambda q: np.abs(np.diff(q[:, 0], 2)).max()  # noqa: E731: the largest change of step
    assert jerk(p[4:-4]) < 0.25 * jerk(pos[4:-4, 0])
    assert (np.abs(np.diff(p[:, 0])) <= 2.0 * dt + 1e-9).all()
    assert out.metadata["relaxed"]["straight_segments"] == 0


def test_an_agent_that_leaves_and_comes_back_keeps_its_own_path():
    pos, dt = _stop_and_go()
    both = np.concatenate([pos, pos + [0.0, 5.0]], axis=1)
    active = np.ones(both.shape[:2], dtype=bool)
    active[10:20, 1] = False  # the second walker is away for ten steps
    out = relaxed_steps(Trajectories(both, dt, radius=np.array([0.25, 0.25]), active=active), 1.0, None,
                        np.array([2.0, 2.0]))
    np.testing.assert_array_equal(out.positions[:, 1], both[:, 1])
    assert not np.array_equal(out.positions[:, 0], both[:, 0])


def test_bodies_the_steps_keep_apart_stay_apart():
    # a file of walkers touching (1 mm apart) that stop and go together, and one standing
    # 1 mm ahead of the file's last position: the relaxed file may not run into it
    from crowdmotion.metrics import collision_audit

    pos, dt = _stop_and_go()
    file = np.concatenate([pos - [0.501 * k, 0.0] for k in range(5)], axis=1)
    stand = np.broadcast_to(pos[-1] + [0.501, 0.0], (len(pos), 1, 2))
    traj = Trajectories(np.concatenate([file, stand], axis=1), dt, radius=np.full(6, 0.25))
    assert collision_audit(traj, None).agent_agent == 0
    out = relaxed_steps(traj, 1.0, None, np.full(6, 2.0))
    assert collision_audit(out, None).agent_agent == 0


def test_a_relaxation_that_puts_most_steps_back_on_the_plan_says_so():
    with pytest.warns(UserWarning, match=r"straight moves on 600 of 1000 path steps \(60 %\)"):
        warn_if_straight({"straight_segments": 600, "segments": 1000})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_if_straight({"straight_segments": 50, "segments": 1000})  # a few steps put back: smooth enough
        warn_if_straight({})


def test_relaxing_a_run_whose_steps_mostly_stay_as_they_were_says_so(monkeypatch):
    import crowdmotion.smoothing as smoothing

    def kept_straight(smooth, linear, traj, scene, max_speed, kind, warn=True):  # every step put back
        out = linear
        out.metadata["resampled"] = {"straight_segments": traj.n_frames - 1, "segments": traj.n_frames - 1}
        return out

    monkeypatch.setattr(smoothing, "keep_clean", kept_straight)
    pos, dt = _stop_and_go()
    with pytest.warns(UserWarning, match=r"straight moves on 40 of 40 path steps"):
        relaxed_steps(Trajectories(pos, dt, radius=np.array([0.25])), 1.0, None, np.array([2.0]))


def test_moves_between_frames_far_apart_are_pushed_off_a_wall_corner():
    # frames a second apart, each clear of the wall, whose straight moves cut its corner
    # (a door's jamb at a large run's steps): the relaxation at the steps pushes the moves off
    # it, so that the continuous audit finds nothing to put back
    from crowdmotion.metrics import collision_audit
    from crowdmotion.path_relaxation import relax
    from crowdmotion.scene import Box, Scene
    from crowdmotion.trajectories import Trajectories

    scene = Scene(((0, 0), (20, 20)), [Box((5, 5), (15, 15))])
    corner = np.array([[2.0, 5.6], [4.6, 5.6], [5.6, 4.6], [5.6, 2.0]])[:, None, :]  # the middle move cuts (5, 5)
    walk = np.concatenate([corner[:1].repeat(3, 0), corner, corner[-1:].repeat(3, 0)])
    act = np.ones(walk.shape[:2], bool)
    assert collision_audit(Trajectories(walk, 1.0, radius=0.25), scene).agent_obstacle > 0
    out = relax(walk, act, np.array([0.25]), 1.0, scene, window_s=1.0, iterations=0, swept=True, settle=5)
    assert collision_audit(Trajectories(out, 1.0, radius=0.25), scene).clean
