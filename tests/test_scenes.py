"""The built-in scenes: collision-free in continuous time, agents gather, seeds matter."""

import warnings

import numpy as np
import pytest

from crowdmotion.cli import builtin_scenarios
from crowdmotion.facing import MAX_TURN_RATE, turn_rate
from crowdmotion.scenario import load_scenario, run_scenario
from tests.io.readers import assert_sqlite_opens_in_pedpy_and_jupedsim, assert_usd_obstacles_where_the_scene_has_them

SCENES = {p.stem: p for p in builtin_scenarios()}
# 2000 people for 266 s: its exports alone take a minute; 2000 MDP agents: relaxing their paths takes 20 s
LARGE = {"rvo_stand_evacuation", "mdp_doorway_2000"}
# walkers' root motion as a DCC plays it: p95 limits (issue 28)
WALKER_LIMITS = {"acceleration_mps2": 2.0, "turn_rate_rad_s": 2.0, "deviation_from_1s_average_m": 0.05}


def _assert_walkers_play_smoothly(name, rm):
    for key, limit in WALKER_LIMITS.items():
        assert rm[key]["p95"] <= limit, (name, key, rm)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in LARGE else n for n in sorted(SCENES)])
def test_builtin_scene_is_clean_gathers_and_opens_in_the_readers(name, tmp_path):
    result = run_scenario(load_scenario(SCENES[name]), progress=False)
    # issue 17: its SQLite in PedPy and JuPedSim, its USD obstacles in pxr
    assert_sqlite_opens_in_pedpy_and_jupedsim(result.trajectories, tmp_path)
    assert_usd_obstacles_where_the_scene_has_them(result.trajectories, tmp_path)
    # issue 14: a facing for every agent and frame, turning at a bounded rate
    traj = result.trajectories
    assert np.isfinite(traj.facing).all() and np.isfinite(traj.facing_pitch).all()
    assert turn_rate(traj.facing, traj.dt).max() <= MAX_TURN_RATE + 1e-6
    s = result.summary
    assert s["agent_agent_overlaps"] == 0, s["first_events"]
    assert s["agent_obstacle_penetrations"] == 0, s["first_events"]
    if result.scenario.method == "mdp":
        assert not s["unreachable_agents"]
        # goals fill (mdp.goal_fill): everyone walks into the goal area, not onto its rim
        assert s["max_final_path_distance_to_goal_m"] <= 1e-9, s
        assert s["arrival_rate"] >= 0.98
        # every agent within its group's max speed; 2D agents (walkers) play without twitching at 24 fps
        from crowdmotion.metrics import root_motion

        ok = traj.active_mask[:-1] & traj.active_mask[1:]
        top = np.concatenate([np.full(g.count, g.max_speed) for g in result.scenario.groups])
        assert (traj.speed[:-1] <= top + 1e-9)[ok].all(), s["max_speed_mps"]
        if traj.dim == 2:
            _assert_walkers_play_smoothly(name, root_motion(traj))
    elif result.scenario.method == "rvo":  # everyone reaches their own goal point
        assert s["arrival_rate"] == 1.0, s
        assert set(s["groups"]) == {g.name for g in result.scenario.groups}
        # walkers (person-sized) walk without twitching at 24 fps as the export plays them
        from crowdmotion.metrics import root_motion
        from crowdmotion.rvo.density import PERSON_MAX_RADIUS_M

        people = np.flatnonzero(traj.radius <= PERSON_MAX_RADIUS_M)
        if len(people):
            _assert_walkers_play_smoothly(name, root_motion(traj.select(agents=people)))
    elif result.scenario.method == "pso":  # every group gathers (threshold or the group arrival rule)
        assert s["arrival_rate"] == 1.0, s
        assert all(s["groups_gathered"].values()), s["groups_gathered"]
        # the relaxed paths (pso.smoothing) fly without twitching at 24 fps, within every group's max speed
        top = np.array([g.max_speed for g in result.scenario.groups])[result.extras.swarm_run.swarm]
        assert (traj.speed[:-1] <= top + 1e-9).all(), s["max_speed_mps"]
        rm = s["root_motion"]
        assert rm["acceleration_mps2"]["p95"] <= 2.0, rm
        assert rm["turn_rate_rad_s"]["p95"] <= 2.0, rm
        assert rm["deviation_from_1s_average_m"]["p95"] <= 0.08, rm
        assert s["smoothing"]["straight_segments"] == 0, s["smoothing"]
    else:  # formation: every group reaches its target area and recovers its shape
        assert s["all_recovered"], s["formation"]
        for name, g in s["formation"].items():
            assert g["recovered_s"] is not None, name
            assert g["edge_length_error_mean"] < 0.02, (name, g)
            assert g["kabsch_rms_m"] < 0.1, (name, g)
        # soldiers (walkers, not cars) walk without twitching at 24 fps, within max speed
        from crowdmotion.metrics import root_motion

        for g in result.extras.simulator.groups:
            if g.cars:
                continue
            walkers = traj.select(agents=g.agents)
            rm = root_motion(walkers)
            assert rm["acceleration_mps2"]["p95"] <= 2.0, (g.name, rm)
            assert rm["turn_rate_rad_s"]["p95"] <= 2.0, (g.name, rm)
            assert rm["deviation_from_1s_average_m"]["p95"] <= 0.05, (g.name, rm)
            assert np.nanmax(walkers.speed) <= g.max_speed + 1e-9, g.name


def test_seed_gives_diversity_and_reproducibility():
    sc = load_scenario(SCENES["mdp_robots_2d"])
    a = run_scenario(sc, seed=1, progress=False).trajectories.positions
    b = run_scenario(sc, seed=1, progress=False).trajectories.positions
    c = run_scenario(sc, seed=2, progress=False).trajectories.positions
    np.testing.assert_array_equal(a, b)
    assert a.shape != c.shape or not np.array_equal(a, c)


def test_smoothed_output_keeps_the_guarantee():
    # issue 15.2: a user asks for catmull-rom smoothing of mdp_robots_2d; the spline alone
    # overlapped 3223 times and reached 2.75 m/s. Agents whose spline would touch another
    # or outrun their max speed keep straight moves.
    from crowdmotion import metrics
    from crowdmotion.mdp import MDPParams, run

    sc = load_scenario(SCENES["mdp_robots_2d"])
    p = sc.params
    for kind in ("linear", "catmull-rom"):
        params = MDPParams(**{**p.__dict__, "smoothing": kind, "fps": 12.0})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = run(sc.scene, sc.groups, params, np.random.default_rng(0))
        tr = res.trajectories
        assert tr.dt == pytest.approx(1 / 12)
        assert metrics.collision_audit(tr, sc.scene).clean, kind
        assert np.nanmax(tr.speed) <= sc.groups[0].max_speed + 1e-9, kind
    r = tr.metadata["resampled"]
    assert 0 < r["straight_segments"] < r["segments"] / 2, "most of each path keeps the spline"
