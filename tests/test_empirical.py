"""The empirical suite's measures against closed forms, and a quick case against the data."""

import numpy as np
import pytest

from crowdmotion import empirical, verify
from crowdmotion.empirical import area_density_speed, lane_order, stationary
from crowdmotion.trajectories import Trajectories


def test_stationary_part_is_the_middle_eighty_percent_of_the_crossings():
    times = np.arange(100) * 0.5  # one person every 0.5 s
    start, end, flow = stationary(times)
    assert (start, end, flow) == (5.0, 45.0, pytest.approx(2.0))
    assert np.isnan(stationary(np.array([1.0, 2.0]))[2])


def test_the_longest_wait_is_the_widest_gap_between_successive_crossings():
    assert empirical.longest_wait(np.array([5.0, 1.0, np.nan, 2.0, 9.5])) == 4.5
    assert np.isnan(empirical.longest_wait(np.array([3.0, np.nan])))


def test_density_and_speed_in_an_area_count_who_is_inside():
    # a file of walkers 1 m apart walking +x at 1.2 m/s through an area 2 m x 1 m
    t = np.arange(50) * 0.1
    x = 1.2 * t[:, None] + np.arange(20)[None] * 1.0 - 12.0
    pos = np.stack([x, np.full_like(x, 0.5)], axis=2)
    traj = Trajectories(pos, 0.1, radius=np.full(20, 0.2))
    rho, v = area_density_speed(traj, (2.0, 0.0), (4.0, 1.0), 0.5, 4.0)
    assert v == pytest.approx(1.2)
    assert rho == pytest.approx(2 / 2.0, abs=0.05)  # two walkers inside at any time (three at the edges)


def test_lane_order_is_one_in_lanes_and_zero_when_directions_alternate():
    pts = np.array([[x, y] for y in (0.0, 1.0) for x in np.arange(0, 6, 0.8)])
    lanes = np.repeat([True, False], len(pts) // 2)
    assert lane_order(pts, lanes) == pytest.approx(1.0)
    file = np.c_[np.arange(0, 8, 0.8), np.zeros(10)]
    alternating = np.arange(10) % 2 == 0
    assert lane_order(file, alternating) < 0.1


def test_measured_fzj_trajectories_are_placed_in_the_model_corridor_and_sampled_as_its_frames(tmp_path):
    # the data archive's format: ID FRAME X Y Z, cm, 16 frames/s, the corridor along Y centred on 0;
    # person 1 walks +Y at 1.6 m/s along X = 90 cm, person 2 -Y at 0.8 m/s along X = 270 cm
    frames = np.arange(0, 65)
    rows = [(1, f, 90.0, -400.0 + 10.0 * f, 170.0) for f in frames]
    rows += [(2, f, 270.0, 400.0 - 5.0 * f, 160.0) for f in frames[8:]]
    path = tmp_path / "bot-360-160-160.txt"
    np.savetxt(path, rows)
    traj = empirical.fzj_bot_trajectories(path)
    assert traj.dt == 0.25 and traj.n_frames == 17  # every fourth frame
    assert list(traj.group) == ["east", "west"]
    assert traj.positions[0, 0] == pytest.approx([9.0, 0.9])  # corridor start (x 9), 0.9 m from its wall
    assert traj.positions[16, 0] == pytest.approx([15.4, 0.9])
    assert not traj.active[0, 1] and not traj.active[1, 1] and traj.active[2, 1]
    assert traj.positions[2, 1] == pytest.approx([16.6, 2.7])
    speeds = np.linalg.norm(np.diff(traj.positions, axis=0), axis=2) / traj.dt
    assert speeds[:, 0] == pytest.approx(1.6)
    assert speeds[2:, 1] == pytest.approx(0.8)


def test_a_file_that_is_not_fzj_trajectories_is_refused_naming_it(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("ID FRAME X Y Z\nfirst second\n")
    with pytest.raises(ValueError, match="notes.txt"):
        empirical.fzj_bot_trajectories(bad)
    short = tmp_path / "short.txt"
    short.write_text("1 0 10\n1 1 11\n")
    with pytest.raises(ValueError, match="short.txt.*ID FRAME X Y Z"):
        empirical.fzj_bot_trajectories(short)
    with pytest.raises(ValueError, match="no such file|not an FZJ"):
        empirical.fzj_bot_trajectories(tmp_path / "missing.txt")


def test_the_counterflow_verdict_sets_a_runs_lanes_beside_the_measured_runs_at_its_density():
    # two opposite lanes walking through the measurement area at 1 /m² (0.5 m apart along x)
    frames = 40
    x = np.arange(-10, 40) * 0.5
    east = np.stack([np.stack([x + 1.2 * 0.25 * f, np.full_like(x, 0.6)], 1) for f in range(frames)])
    west = np.stack([np.stack([x[::-1] - 1.2 * 0.25 * f, np.full_like(x, 3.0)], 1) for f in range(frames)])
    pos = np.concatenate([east, west], axis=1)
    group = np.array(["east"] * len(x) + ["west"] * len(x))
    traj = Trajectories(pos, 0.25, group=group, radius=0.2)
    outcome = empirical.Outcome(None, traj, {"arrival_rate": 1.0}, 0.0)
    _, measured, passed = empirical._judge_bot({"lanes/0": outcome})
    rho = empirical.bot_measures(traj, np.random.default_rng(0))[0]
    real = min(empirical.BOT_360_LANE_RATIOS, key=lambda r: abs(r[0] - rho))
    assert f"FZJ at {real[0]:.2f}/m² {real[1]:.2f}x" in measured
    assert "lanes 1.00 vs" in measured


def _two_lanes(y_east: float, y_west: float, west_speed: float = -1.2) -> Trajectories:
    """An east lane at ``y_east`` walking 1.2 m/s and a west lane at ``y_west`` moving
    ``west_speed`` along x, each a body every 0.5 m, through the measurement area."""
    x = np.arange(-40, 80) * 0.5  # long enough to fill the area ahead at every frame
    east = np.stack([np.stack([x + 1.2 * 0.25 * f, np.full_like(x, y_east)], 1) for f in range(40)])
    west = np.stack([np.stack([x[::-1] + west_speed * 0.25 * f, np.full_like(x, y_west)], 1) for f in range(40)])
    group = np.array(["east"] * len(x) + ["west"] * len(x))
    return Trajectories(np.concatenate([east, west], axis=1), 0.25, group=group, radius=0.2)


def test_walkers_meet_the_oncoming_stream_only_when_one_must_step_aside_to_pass():
    apart = empirical.bot_passing(_two_lanes(0.6, 3.0))  # 2.4 m across: they pass without a step aside
    assert apart.meeting == 0.0 and apart.speed_others == pytest.approx(1.2)
    assert np.isnan(apart.speed_meeting) and apart.backwards == 0.0
    close = empirical.bot_passing(_two_lanes(1.6, 2.0))  # 0.4 m across: nose to shoulder
    assert close.meeting == 1.0 and close.speed_meeting == pytest.approx(1.2) and close.stopped == 0.0


def test_walkers_keeping_their_lane_to_the_corridors_end_keep_their_side_and_crossers_do_not():
    kept, corr = empirical.bot_exit_sides(_two_lanes(0.9, 2.7))
    assert kept == 1.0 and corr == pytest.approx(1.0)
    traj = _two_lanes(0.9, 2.7)
    p = traj.positions.copy()
    east = np.flatnonzero(traj.group == "east")
    p[..., east, 1] = np.where(p[..., east, 0] > 14.0, 2.7, 0.9)  # the east lane crosses over past mid-corridor
    kept, corr = empirical.bot_exit_sides(Trajectories(p, 0.25, group=traj.group, radius=0.2))
    assert kept == pytest.approx(0.5, abs=0.05)


def test_a_walker_stepping_back_before_the_oncoming_stream_counts_as_stopped_and_backwards():
    passing = empirical.bot_passing(_two_lanes(1.6, 2.0, west_speed=0.3))  # the west lane drifts east
    assert passing.meeting == 1.0
    assert passing.backwards == pytest.approx(0.5, abs=0.05)  # one walker in two, at every moment
    assert passing.stopped == pytest.approx(0.5, abs=0.05)
    assert passing.speed_meeting == pytest.approx((1.2 - 0.3) / 2, abs=0.05)


def test_every_empirical_case_cites_its_source_and_runs_the_rvo_method():
    assert {c.name for c in empirical.CASES} == {"fd_open_corridor", "bottleneck_flow", "narrow_door",
                                                 "counterflow_lanes"}
    assert all(c.source and c.methods == ("rvo",) for c in empirical.CASES)
    assert verify.select(empirical=True, names=["bottleneck_flow"])[0][0].name == "bottleneck_flow"


def test_a_one_metre_bottleneck_passes_a_dense_crowd_at_the_measured_flow():
    # 200 persons, 10 x 8 m room, 2 m long bottleneck of 1 m: the experiments' mean is 1.86 /s
    setup = empirical._bottleneck("rvo")["b 1"]
    out = verify.simulate("rvo", setup, seed=0)
    flow = empirical.bottleneck_flows({"b 1/0": out})[1.0]
    assert flow == pytest.approx(np.mean(empirical.BOTTLENECK_FLOWS[1.0]), rel=0.25)
    assert out.summary["arrival_rate"] == 1.0 and out.summary["agent_agent_overlaps"] == 0


def test_verify_empirical_runs_a_named_case_and_writes_its_table(tmp_path, capsys, monkeypatch):
    from crowdmotion.cli import main

    monkeypatch.setattr(empirical, "BOTTLENECK_WIDTHS", (1.0,))
    code = main(["verify", "--empirical", "--case", "bottleneck_flow", "-o", str(tmp_path), "-q", "-j", "1"])
    out = capsys.readouterr().out
    assert "| bottleneck_flow | rvo |" in out and "1 m: " in out and (tmp_path / "verify.json").exists()
    assert code == 0


def test_a_07_m_door_passes_a_dense_crowd_at_one_person_a_second_or_more():
    # Kretz et al. measured about 1.2 /s; two pressed abreast in the door must not wedge it
    case = next(c for c in empirical.CASES if c.name == "narrow_door")
    out = {name: verify.simulate("rvo", setup) for name, setup in case.build("rvo").items()}
    criterion, measured, passed = case.judge(out)
    assert passed, measured
    assert "longest wait between two passing: " in measured


def test_the_counterflow_walkers_have_the_bot_participants_free_speed_the_others_weidmanns():
    # the BOT-360 participants walked 1.52 m/s at 0.45 /m²; through the density-speed
    # relation (Weidmann's form, gamma 1.63) that is a free speed near 1.58 m/s
    assert 1.55 < empirical.BOT_FREE_SPEED < 1.60
    for g in empirical._bot("rvo")["BOT b 0.9"].groups:
        low, high = g.attributes["pref_speed_range"]
        assert (low, high) == (1.34, 1.82) and g.max_speed >= high
    for setup in (*empirical._uo("rvo").values(), *empirical._bottleneck("rvo").values()):
        for g in setup.groups:
            assert abs(g.pref_speed - 1.34) < 1e-9
