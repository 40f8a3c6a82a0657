"""Locomotion channels: distance, gait phase from the stride model, a state with
hysteresis, turn rate and foot contacts, checked on small closed-form paths."""

import math

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.locomotion import (IDLE, MOVE, RUN, STATES, TURN, WALK, LocomotionParams, body_kinds, cadence,
                                    locomotion, step_length)

DT = 1 / 24
L_REF, V_REF = 0.72, 1.34  # the documented stride model: L(v) = 0.72 m · sqrt(v / 1.34 m/s)


def straight(speeds, seconds=6.0, dt=DT):
    """Agents walking east at constant speeds, one row each."""
    t = np.arange(int(round(seconds / dt)) + 1) * dt
    pos = np.zeros((len(t), len(speeds), 2))
    pos[:, :, 0] = t[:, None] * np.asarray(speeds)[None, :]
    pos[:, :, 1] = np.arange(len(speeds)) * 2.0
    return Trajectories(pos, dt)


def runs(states):
    """(state, length) of each run of one agent's states."""
    cut = np.flatnonzero(np.diff(states)) + 1
    return [(int(s[0]), len(s)) for s in np.split(states, cut)]


def test_constant_speed_walk_distance_is_v_t_and_the_phase_turns_at_half_the_cadence():
    v = 1.3
    tr = straight([v])
    loco = locomotion(tr)
    np.testing.assert_allclose(loco.distance[:, 0], v * tr.times, atol=1e-9)
    assert (loco.gait_state[:, 0] == WALK).all()
    # closed form: cadence v / L(v) = sqrt(v · v_ref) / L_ref steps/s; a stride is two steps
    strides_per_s = math.sqrt(v * V_REF) / L_REF / 2
    np.testing.assert_allclose(np.diff(np.unwrap(loco.gait_phase[:, 0], period=1.0)) / DT, strides_per_s, rtol=1e-9)
    assert cadence(v) == pytest.approx(1.83, abs=0.01) and step_length(v) == pytest.approx(0.709, abs=0.001)
    assert 1.8 <= cadence(v) <= 2.0 and 0.7 <= step_length(v) <= 0.8  # empirical-references.md, free walking


def test_the_phase_wraps_once_per_stride_and_never_jumps():
    v = 1.0
    tr = straight([v], seconds=10.0)
    phase = locomotion(tr).gait_phase[:, 0]
    assert ((phase >= 0) & (phase < 1)).all()
    step = np.diff(phase)
    wraps = step < -0.5
    assert np.abs(step[~wraps]).max() < 0.05  # continuous between wraps
    stride = 2 * L_REF * math.sqrt(v / V_REF)
    assert wraps.sum() == pytest.approx(v * 10.0 / stride, abs=1.0)


def test_characters_at_different_speeds_step_at_different_rates():
    slow, fast = 0.8, 1.6
    loco = locomotion(straight([slow, fast]))
    rate = np.diff(np.unwrap(loco.gait_phase, period=1.0, axis=0), axis=0).mean(axis=0) / DT
    np.testing.assert_allclose(rate, [math.sqrt(s * V_REF) / (2 * L_REF) for s in (slow, fast)], rtol=1e-9)
    assert rate[1] / rate[0] == pytest.approx(math.sqrt(fast / slow))


def test_agents_start_at_spread_phases_unless_told_not_to():
    loco = locomotion(straight([1.0] * 4))
    assert len(set(np.round(loco.gait_phase[0], 6))) == 4
    flat = locomotion(straight([1.0] * 4), LocomotionParams(stagger=False))
    np.testing.assert_array_equal(flat.gait_phase[0], 0.0)


def test_a_standing_character_is_idle_with_both_feet_down_and_its_phase_held():
    pos = np.zeros((48, 1, 2))
    loco = locomotion(Trajectories(pos, DT))
    assert (loco.gait_state == IDLE).all()
    assert loco.contact_left.all() and loco.contact_right.all()
    assert np.ptp(loco.gait_phase) == 0 and (loco.distance == 0).all() and (loco.turn_rate == 0).all()


def test_walking_feet_alternate_with_double_support_and_running_has_flight():
    walk = locomotion(straight([1.3], seconds=20.0))
    left, right = walk.contact_left[:, 0], walk.contact_right[:, 0]
    assert left.mean() == pytest.approx(0.6, abs=0.02) and right.mean() == pytest.approx(0.6, abs=0.02)
    assert (left & right).mean() == pytest.approx(0.2, abs=0.02)  # two double-support spells of 10 %
    assert (left | right).all()  # walking: never both feet off
    run = locomotion(straight([3.0], seconds=20.0))
    assert (run.gait_state[:, 0] == RUN).all()
    left, right = run.contact_left[:, 0], run.contact_right[:, 0]
    assert left.mean() == pytest.approx(0.35, abs=0.02) and not (left & right).any()
    assert (~left & ~right).mean() == pytest.approx(0.3, abs=0.02)  # flight


def test_left_foot_strikes_at_phase_zero_right_at_half():
    loco = locomotion(straight([1.3], seconds=5.0), LocomotionParams(stagger=False))
    phase, left, right = loco.gait_phase[:, 0], loco.contact_left[:, 0], loco.contact_right[:, 0]
    strikes_left = np.flatnonzero(left[1:] & ~left[:-1]) + 1
    strikes_right = np.flatnonzero(right[1:] & ~right[:-1]) + 1
    step = np.diff(phase).max()
    assert np.all(np.minimum(phase[strikes_left], 1 - phase[strikes_left]) <= step + 1e-9)
    assert np.all(np.abs(phase[strikes_right] - 0.5) <= step + 1e-9)


def test_a_quarter_turn_on_the_spot_is_a_turn_at_its_rate():
    rate = math.pi / 2  # 90° in 1 s
    n = 72
    yaw = np.zeros(n)
    yaw[24:48] = rate * DT * np.arange(1, 25)
    yaw[48:] = math.pi / 2
    tr = Trajectories(np.zeros((n, 1, 2)), DT, facing=yaw[:, None], metadata={"facing": "given"})
    loco = locomotion(tr)
    np.testing.assert_allclose(loco.turn_rate[26:47, 0], rate, rtol=1e-9)
    assert loco.turn_rate[:, 0].sum() * DT == pytest.approx(math.pi / 2, rel=1e-9)  # the whole quarter turn
    state = loco.gait_state[:, 0]
    assert (state[27:47] == TURN).all() and (state[:20] == IDLE).all() and (state[54:] == IDLE).all()
    assert loco.contact_left[:, 0].all() and loco.contact_right[:, 0].all()  # stepping round: both down
    # turning right is negative
    tr.facing = -tr.facing
    assert (locomotion(tr).turn_rate[26:47, 0] == pytest.approx(-rate))


def test_speed_in_the_hysteresis_band_keeps_the_state_it_had():
    p = LocomotionParams()
    speed = np.r_[np.full(48, 1.0), np.full(48, 0.2), np.full(48, 0.0), np.full(48, 0.2)]  # 0.2: between stop and start
    x = np.concatenate([[0.0], np.cumsum(speed[1:] * DT)])
    pos = np.column_stack([x, np.zeros_like(x)])[:, None, :]
    state = locomotion(Trajectories(pos, DT), p).gait_state[:, 0]
    assert (state[60:90] == WALK).all()  # slowed into the band: still walking
    assert (state[110:] == IDLE).all()  # stopped, then crept at 0.2 m/s: still idle


def test_no_state_flickers_for_less_than_min_state_s_on_a_noisy_speed():
    rng = np.random.default_rng(5)
    t = 1200
    # a speed wandering across both walk thresholds and the run thresholds
    speed = np.clip(1.0 + np.cumsum(rng.normal(0, 0.08, t)), 0, 3)
    speed += rng.normal(0, 0.2, t)
    x = np.concatenate([[0.0], np.cumsum(np.abs(speed[1:]) * DT)])
    pos = np.column_stack([x, np.zeros_like(x)])[:, None, :]
    state = locomotion(Trajectories(pos, DT)).gait_state[:, 0]
    seen = runs(state)
    assert len(seen) > 5  # it does change state
    inner = [length for _, length in seen[1:-1]]
    assert min(inner) * DT >= 0.3 - 1e-9


def test_a_short_stop_between_walks_does_not_show():
    speed = np.r_[np.full(48, 1.2), np.full(4, 0.0), np.full(48, 1.2)]  # 1/6 s standing still
    x = np.concatenate([[0.0], np.cumsum(speed[1:] * DT)])
    pos = np.column_stack([x, np.zeros_like(x)])[:, None, :]
    loco = locomotion(Trajectories(pos, DT), LocomotionParams(speed_window_s=DT * 2))
    assert (loco.gait_state[:, 0] == WALK).all()


def test_inactive_frames_are_idle_and_a_jump_across_them_is_no_distance():
    tr = straight([1.0], seconds=4.0)
    tr.positions[50:60, 0, 0] += 30.0  # teleported while inactive
    active = np.ones((tr.n_frames, 1), bool)
    active[50:60] = False
    tr = Trajectories(tr.positions, DT, active=active)
    loco = locomotion(tr)
    assert (loco.gait_state[50:60, 0] == IDLE).all()
    assert loco.distance[-1, 0] == pytest.approx((tr.n_frames - 1 - 11) * DT * 1.0)


def test_cars_and_drones_get_distance_move_state_and_turn_rate_but_no_gait():
    tr = straight([5.0, 1.0])
    tr.metadata["bodies"] = {"agents": "car"}
    loco = locomotion(tr)
    assert (loco.gait_state == MOVE).all() and np.isnan(loco.gait_phase).all()
    assert not loco.contact_left.any() and not loco.contact_right.any()
    np.testing.assert_allclose(loco.distance[-1], [30.0, 6.0])
    pos = np.zeros((30, 1, 3))
    pos[:, 0, 2] = np.arange(30) * 0.1
    drone = Trajectories(pos, 0.1)
    assert body_kinds(drone).tolist() == ["drone"]
    assert locomotion(drone).gait_state[10, 0] == MOVE
    assert body_kinds(drone, {"agents": "walker"}).tolist() == ["walker"]


def test_formation_runs_name_their_cars():
    import crowdmotion as cm

    scene = cm.Scene(bounds=([0, -10], [60, 10]))
    cars = cm.Group("traffic", 4, spawn=[5.0, 0.0], goal=[40.0, 0.0], radius=0.3, pref_speed=4.0, max_speed=8.0,
                    attributes={"formation": {"kind": "cars", "lanes": 1, "per_lane": 2, "car_width": 1.8,
                                              "car_gap": 8.0, "lane_width": 4.0}})
    from crowdmotion.formation.simulation import simulate

    tr = simulate(scene, [cars], {"max_steps": 5}, np.random.default_rng(0))
    assert tr.metadata["bodies"] == {"traffic": "car"}
    assert body_kinds(tr).tolist() == ["car"] * 4


@pytest.mark.parametrize("field, value, message", [
    ("walk_start", float("nan"), "walk_start must be a finite number, got nan"),
    ("step_length_m", -0.7, "step_length_m must be positive, got -0.7"),
    ("walk_stop", 0.5, r"walk_stop \(0.5\) must not exceed walk_start"),
    ("walk_duty", 1.2, "walk_duty must lie between 0 and 1, got 1.2"),
    ("stagger", "yes", "stagger must be True or False"),
])
def test_bad_parameters_are_refused_by_name(field, value, message):
    with pytest.raises(ValueError, match=message):
        LocomotionParams(**{field: value})


def test_a_bad_body_kind_is_refused_by_name():
    with pytest.raises(ValueError, match="group 'agents' must be one of walker, car, drone, got 'horse'"):
        locomotion(straight([1.0]), kinds={"agents": "horse"})


def test_states_are_named():
    assert STATES[IDLE] == "idle" and STATES[WALK] == "walk" and STATES[RUN] == "run" and STATES[TURN] == "turn"


def test_positions_of_inactive_agents_may_be_nan_but_not_of_active_ones():
    tr = straight([1.0, 1.0], seconds=2.0)
    active = np.ones((tr.n_frames, 2), bool)
    active[20:, 1] = False
    tr.positions[20:, 1] = np.nan  # gone: where it stands is no one's business
    loco = locomotion(Trajectories(tr.positions, DT, active=active))
    assert np.isfinite(loco.distance).all() and loco.distance[-1, 1] == pytest.approx(19 * DT)
    tr.positions[5, 0, 1] = np.nan
    with pytest.raises(ValueError, match="positions of agent 0 at frame 5 is not finite: nan"):
        locomotion(Trajectories(tr.positions, DT, active=active))


def test_a_walker_that_stops_takes_its_closing_steps_then_stands_with_both_feet_down():
    # walks east at 1.3 m/s for 3 s, then stands for 3 s
    t = np.arange(0, 145) * DT
    pos = np.zeros((len(t), 1, 2))
    pos[:, 0, 0] = 1.3 * np.minimum(t, 3.0)
    loco = locomotion(Trajectories(pos, DT))
    state, phase = loco.gait_state[:, 0], np.unwrap(loco.gait_phase[:, 0], period=1.0)
    left, right = loco.contact_left[:, 0], loco.contact_right[:, 0]
    stop = int(np.flatnonzero(state == WALK)[-1]) + 1  # the first standing frame
    assert (state[stop:] == IDLE).all()
    # after the stop each foot strikes once more (a heel strike: down after being up) ...
    for foot in (left, right):
        strikes = np.flatnonzero(foot[stop:][1:] & ~foot[stop:][:-1])
        assert len(strikes) == 1
    # ... at the reference cadence (0.93 strides/s; the first and last frames take it for
    # the part of their step after the stop and before the last strike), within a stride,
    # and then stands
    rate = np.diff(phase[stop - 1:])
    run_on = rate > 0
    np.testing.assert_allclose(rate[run_on][1:-1], cadence(V_REF) / 2 * DT, rtol=1e-9)
    assert (rate[run_on] <= cadence(V_REF) / 2 * DT + 1e-12).all()
    assert run_on.sum() * DT <= 1 / (cadence(V_REF) / 2) + DT
    settled = stop + int(np.flatnonzero(run_on)[-1]) + 1
    assert left[settled:].all() and right[settled:].all() and np.ptp(phase[settled:]) == 0
    assert settled < len(t) - 24
    # without them the phase holds from the stop
    held = locomotion(Trajectories(pos, DT), LocomotionParams(gait_transitions=False))
    assert np.ptp(held.gait_phase[stop:, 0]) == 0 and held.contact_left[stop:, 0].all()


def test_a_walker_setting_off_takes_its_first_stride_at_least_at_the_reference_cadence():
    # stands 2 s, then speeds up at 0.8 m/s² to 1.3 m/s
    t = np.arange(0, 145) * DT
    speed = np.clip((t - 2.0) * 0.8, 0.0, 1.3)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * DT)])
    tr = Trajectories(np.column_stack([x, np.zeros_like(x)])[:, None, :], DT)
    loco, plain = locomotion(tr), locomotion(tr, LocomotionParams(gait_transitions=False))
    phase = np.unwrap(loco.gait_phase[:, 0], period=1.0)
    off = int(np.flatnonzero(loco.gait_state[:, 0] == WALK)[0])
    reference = cadence(V_REF) / 2 * DT  # strides a frame
    # both feet strike once before the phase may follow the (slow) speed again
    strikes = [off + int(np.flatnonzero(f[off:][1:] & ~f[off:][:-1])[0]) + 1
               for f in (loco.contact_left[:, 0], loco.contact_right[:, 0])]
    opening = slice(off, max(strikes) - 1)
    plain_rate = np.diff(np.unwrap(plain.gait_phase[:, 0], period=1.0))
    assert (np.diff(phase)[opening] >= reference - 1e-12).all()
    assert (np.diff(phase)[opening] > plain_rate[opening]).any()
    # the step the second foot strikes in: the reference rate up to the strike, its own after it
    last = max(strikes) - 1
    assert plain_rate[last] - 1e-12 <= np.diff(phase)[last] <= reference + 1e-12
    # the ground the body covers over the foot that is down when it sets off: well under
    # the 0.6 stride (0.85 m) of a stance at walking pace, and less than without them

    def first_stance(lo):
        lifts = [off + int(np.flatnonzero(~f[off:, 0])[0]) for f in (lo.contact_left, lo.contact_right) if f[off, 0]]
        return x[max(lifts)] - x[off]

    assert first_stance(loco) < 0.5 and first_stance(loco) < first_stance(plain)
    np.testing.assert_allclose(np.diff(phase)[max(strikes) + 2:],
                               np.diff(np.unwrap(plain.gait_phase[:, 0], period=1.0))[max(strikes) + 2:], atol=1e-12)


def test_walkers_that_stop_and_set_off_again_have_the_same_gait_at_the_same_instants_at_24_and_30_fps():
    from crowdmotion.trajectories import resample

    # 48 walkers at 1.3 m/s slow to a stop over 1 s (each 0.0185 s after the one before, so
    # that they stop at points all along their stride), stand, and set off again 3 s later
    dt = 1 / 120
    t = np.arange(int(round(12 / dt)) + 1) * dt
    pos = np.zeros((len(t), 48, 2))
    for i in range(48):
        slow = 3.0 + 0.0185 * i
        v = np.where(t < slow, 1.3, 1.3 * np.clip(slow + 1.0 - t, 0.0, 1.0))
        v = np.where(t >= slow + 3.0, 1.3 * np.clip(t - slow - 3.0, 0.0, 1.0), v)
        pos[:, i, 0] = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
        pos[:, i, 1] = 2.0 * i
    run = Trajectories(pos, dt)
    at24, at30 = locomotion(resample(run, 24)), locomotion(resample(run, 30))
    n = min(-(-at24.gait_state.shape[0] // 4), -(-at30.gait_state.shape[0] // 5))  # every 1/6 s: in both

    def common(channel, every):
        return channel[::every][:n]

    state = common(at24.gait_state, 4)
    assert ((state == IDLE).any(axis=0) & (state == WALK).any(axis=0)).all()  # each stops and walks again
    np.testing.assert_array_equal(state, common(at30.gait_state, 5))
    # the same phase, to the thousandth of a stride that the paths' speeds at the two rates
    # explain: through the closing steps (which end on the same foot at both rates; decided
    # on the frames, a frame apart, they would swap one walker's feet here), the standing
    # and the opening steps
    phase = common(at24.gait_phase, 4)
    apart = np.abs((phase - common(at30.gait_phase, 5) + 0.5) % 1.0 - 0.5)
    assert apart.max() < 0.002
    # and so the same feet down, but within that of a foot's strike or lift
    edges = np.array([0.0, 0.6, 0.5, 0.1, 1.0])  # left strike, lift; right strike, lift (1.1); the next left strike
    clear = np.abs(phase[..., None] - edges).min(axis=-1) > 0.002
    for foot in ("contact_left", "contact_right"):
        np.testing.assert_array_equal(common(getattr(at24, foot), 4)[clear], common(getattr(at30, foot), 5)[clear])


def test_a_runs_files_and_its_player_share_one_derivation_of_the_channels(tmp_path, monkeypatch):
    import crowdmotion.locomotion as module
    from crowdmotion.io import read_locomotion
    from crowdmotion.render.player import player_data

    calls = []
    derive = module.locomotion
    monkeypatch.setattr(module, "locomotion", lambda *a, **k: calls.append(a[1:]) or derive(*a, **k))
    t = np.arange(97) / 24
    pos = np.stack([np.stack([1.3 * t, np.zeros_like(t)], 1), np.stack([np.zeros_like(t), 0.7 * t], 1)], 1)
    tr = Trajectories(pos, 1 / 24)
    for suffix in ("parquet", "csv", "sqlite", "usda"):
        tr.save(tmp_path / f"run.{suffix}")
    player_data(tr)
    assert len(calls) == 1  # once for every file and the player
    expected = derive(tr)
    for suffix in ("parquet", "csv", "sqlite", "usda"):
        np.testing.assert_allclose(read_locomotion(tmp_path / f"run.{suffix}").gait_phase, expected.gait_phase, atol=1e-6)
    other = LocomotionParams(min_state_s=0.5)
    tr.save(tmp_path / "other.parquet", locomotion=other)
    assert len(calls) == 2 and calls[-1] == (other,)  # other parameters: their own channels
    tr.positions = tr.positions * 2.0  # new positions: derived again
    tr.save(tmp_path / "faster.parquet")
    assert len(calls) == 3
    np.testing.assert_allclose(read_locomotion(tmp_path / "faster.parquet").distance[-1], 2 * expected.distance[-1],
                               rtol=1e-6)
