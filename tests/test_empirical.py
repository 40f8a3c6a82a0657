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
