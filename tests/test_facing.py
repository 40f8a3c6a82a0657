"""Facing (issue 14, item 5): smooth, bounded turn rate, defined while standing, the
direction of travel for walkers; carried by Trajectories and every exporter."""

import numpy as np
import pytest

from crowdmotion.facing import MAX_TURN_RATE, facing_from_motion, turn_rate, wrap
from crowdmotion.trajectories import Trajectories, resample


def _walk(points, steps_each=20):
    """Positions along a polyline at constant speed, ``steps_each`` frames per leg."""
    out = [np.asarray(points[0], float)]
    for a, b in zip(points[:-1], points[1:]):
        a, b = np.asarray(a, float), np.asarray(b, float)
        out += [a + (b - a) * k / steps_each for k in range(1, steps_each + 1)]
    return np.array(out)


def test_standing_agents_face_where_they_will_go_and_hold_it_after():
    dt = 0.1
    stand = np.zeros((30, 2))
    walk = np.column_stack([np.zeros(40), np.linspace(0, 4, 40)])  # north at 1 m/s
    p = np.concatenate([stand, walk, np.repeat(walk[-1:], 30, axis=0)])[:, None, :]
    yaw, pitch = facing_from_motion(p, dt)
    assert np.isfinite(yaw).all()
    np.testing.assert_allclose(yaw[:, 0], np.pi / 2, atol=1e-9)  # before, during and after the walk
    assert not pitch.any()


def test_an_agent_that_never_moves_faces_plus_x():
    yaw, _ = facing_from_motion(np.zeros((10, 1, 2)), 0.1)
    assert np.all(yaw == 0.0)


def test_jitter_and_crawling_backwards_do_not_flip_the_facing():
    rng = np.random.default_rng(3)
    dt = 0.1
    x = np.arange(100) * 0.13  # 1.3 m/s east
    p = np.column_stack([x, np.zeros(100)])
    p[60:] = p[59]  # arrived: then pushed about at a crawl, partly backwards
    p[60:] += np.cumsum(rng.normal(0, 0.004, (40, 2)), axis=0)
    p[60:, 0] -= 0.002 * np.arange(40)  # 2 cm/s backwards
    yaw, _ = facing_from_motion(p[:, None, :], dt)
    assert np.abs(wrap(yaw[:, 0])).max() < np.radians(10)  # east all along: no flip


def test_turn_rate_is_bounded_on_a_reversal_and_on_noise():
    dt = 0.05
    there = np.linspace(0, 5, 50)
    p = np.concatenate([there, there[::-1]])  # straight back: a half turn
    pos = np.zeros((100, 2, 2))
    pos[:, 0, 0] = p
    pos[:, 1] = np.random.default_rng(0).normal(0, 0.3, (100, 2)).cumsum(axis=0)  # a random walk
    yaw, _ = facing_from_motion(pos, dt)
    rate = turn_rate(yaw, dt)
    assert rate.max() <= MAX_TURN_RATE + 1e-9
    assert abs(abs(yaw[-1, 0]) - np.pi) < 1e-9  # it did turn round


def test_a_stair_step_grid_path_faces_its_mean_direction():
    # an MDP walker going north-east on a 4-connected grid: east, north, east, north ...
    moves = np.array([[1, 0], [0, 1]] * 30, float) * 0.5
    p = np.vstack([[0, 0], np.cumsum(moves, axis=0)])[:, None, :]
    dt = 0.4  # 0.5 m cells at 1.25 m/s
    yaw, _ = facing_from_motion(p, dt, window_s=1.6)
    heading = np.arctan2(np.diff(p[:, 0, 1]), np.diff(p[:, 0, 0]))
    assert np.ptp(heading) == pytest.approx(np.pi / 2)  # the velocity flips by 90 degrees each step
    mid = yaw[5:-5, 0]
    assert np.abs(mid - np.pi / 4).max() < np.radians(1)  # the facing does not


def test_3d_climb_gives_the_climb_angle_and_hovering_is_level():
    dt = 0.1
    t = np.arange(40) * dt
    climb = np.column_stack([t, np.zeros(40), t * np.tan(np.radians(30))])
    hover = np.repeat(climb[-1:], 30, axis=0)
    p = np.concatenate([climb, hover])[:, None, :]
    yaw, pitch = facing_from_motion(p, dt)
    assert np.degrees(pitch[5:35, 0]) == pytest.approx(30, abs=1e-6)
    assert pitch[-1, 0] == 0.0  # levelled out while hovering, at the bounded rate
    assert turn_rate(pitch, dt).max() <= MAX_TURN_RATE + 1e-9
    assert np.all(yaw == 0.0)


def test_trajectories_derive_facing_or_take_the_methods_own():
    p = _walk([(0, 0), (10, 0)])[:, None, :]
    traj = Trajectories(p, 0.1)
    assert traj.facing.shape == (21, 1) and np.all(traj.facing == 0)
    own = np.full((21, 1), 1.0)
    assert np.all(Trajectories(p, 0.1, facing=own).facing == 1.0)
    with pytest.raises(ValueError, match=r"Trajectories.facing must have shape \(21, 1\)"):
        Trajectories(p, 0.1, facing=np.zeros((3, 1)))
    with pytest.raises(ValueError, match="facing.*NaN"):
        Trajectories(p, 0.1, facing=np.full((21, 1), np.nan))
    sub = traj.select(frames=slice(2, 5))
    assert sub.facing.shape == (3, 1)


def test_resampling_turns_a_methods_facing_the_short_way_round():
    p = np.zeros((2, 1, 2))
    own = np.array([[np.radians(170)], [np.radians(-170)]])
    traj = Trajectories(p, 1.0, facing=own, metadata={"facing": "test: given"})
    out = resample(traj, 4.0)
    deg = np.degrees(np.unwrap(out.facing[:, 0]))
    np.testing.assert_allclose(deg, [170, 175, 180, 185, 190], atol=1e-9)


@pytest.mark.parametrize("suffix", [".parquet", ".csv", ".sqlite", ".usda"])
def test_exporters_keep_the_facing(tmp_path, suffix):
    rng = np.random.default_rng(1)
    p = rng.normal(0, 1, (15, 4, 2)).cumsum(axis=0)
    own = wrap(rng.uniform(-4, 4, (15, 4)))
    traj = Trajectories(p, 0.1, facing=own, metadata={"facing": "test: given"})
    back = Trajectories.load(traj.save(tmp_path / f"t{suffix}", **({"dcc_rate": False} if suffix == ".usda" else {})))
    tol = 2e-3 if suffix == ".usda" else 1e-6  # USD stores half-precision quaternions
    np.testing.assert_allclose(wrap(back.facing - own), 0, atol=tol)


@pytest.mark.parametrize("suffix", [".parquet", ".usda"])
def test_3d_files_keep_the_facing_pitch(tmp_path, suffix):
    t = np.arange(20) * 0.1
    p = np.column_stack([t, 0.3 * t, 0.5 * t])[:, None, :]
    traj = Trajectories(p, 0.1)
    back = Trajectories.load(traj.save(tmp_path / f"t{suffix}", **({"dcc_rate": False} if suffix == ".usda" else {})))
    tol = 2e-3 if suffix == ".usda" else 1e-12
    np.testing.assert_allclose(back.facing_pitch, traj.facing_pitch, atol=tol)
    np.testing.assert_allclose(wrap(back.facing - traj.facing), 0, atol=tol)
    assert np.degrees(back.facing_pitch[10, 0]) == pytest.approx(np.degrees(np.arctan2(0.5, np.hypot(1, 0.3))),
                                                                  abs=0.2)


def test_a_walker_that_stood_turns_to_its_new_way_before_it_sets_off_not_while():
    # a plaza's walker stood facing west, then walked east: its facing was still 124° off
    # at 0.53 m/s (walking off backwards while turning at 4 rad/s)
    dt = 1 / 24
    west = np.c_[np.linspace(10.0, 5.0, 97), np.zeros(97)]  # 4 s walking west at 1.25 m/s
    stand = np.repeat(west[-1:], 72, axis=0)  # 3 s standing
    speed = np.minimum(np.arange(1, 97) * dt / 1.0, 1.0) * 1.3  # sets off east, 1 s to 1.3 m/s
    east = west[-1] + np.c_[np.cumsum(speed * dt), np.zeros(96)]
    pos = np.vstack([west, stand, east])[:, None, :]
    yaw, _ = facing_from_motion(pos, dt)
    v = np.gradient(pos[:, 0, 0], dt)
    walking_east = np.flatnonzero(v > 0.3)
    assert np.all(np.abs(wrap(yaw[walking_east, 0])) < np.radians(45)), "faces east once walking east"
    assert np.abs(wrap(yaw[100, 0] - np.pi)) < 1e-6, "stood facing west, the way it came, until near setting off"


def test_the_causal_turn_follows_a_moving_agents_velocity_at_the_bounded_rate_and_holds_a_standing_one():
    from crowdmotion.facing import turn_towards

    yaw = np.array([0.0, 0.0, np.nan, 3.0, 0.0])
    v = np.array([[0.0, 1.0],      # a quarter turn away: turns max_step towards it
                  [0.05, 0.05],    # a crawl below min_speed: holds
                  [-1.0, 0.0],     # no facing yet: takes the heading at once
                  [-1.0, -0.01],   # just past pi: the short way round, wrapped into [-pi, pi)
                  [1.0, 0.0]])     # not stepped: holds
    out = turn_towards(yaw, v, np.full(5, 0.3), 0.1, np.array([True, True, True, True, False]))
    assert out[0] == pytest.approx(0.1) and out[1] == 0.0 and out[4] == 0.0
    assert out[2] == pytest.approx(-np.pi)
    assert out[3] == pytest.approx(wrap(3.0 + 0.1)) and -np.pi <= out[3] < np.pi
    assert np.isnan(yaw[2]), "the input is not changed"
