"""Density-aware speed (rvo.density): Weidmann's curve, the FZJ fit, the walkable floor,
and crowds that slow as real ones do."""

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.special import erf, ndtr

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.empirical import UG_RUNS, UO_AREA, area_density_speed, open_corridor, stationary
from crowdmotion.groups import Group, Rect
from crowdmotion._contact import grid_for
from crowdmotion.rvo.density import GAMMA, SIGMA_M, DensitySlowing, FloorShare, speed_share, weidmann_speed
from crowdmotion.verify import crossing_times


def test_weidmanns_curve_gives_the_published_speeds():
    # empirical-references.md: 1.06, 0.61, 0.33, 0.16 m/s at 1, 2, 3, 4 persons/m²
    assert np.allclose(weidmann_speed([1, 2, 3, 4]), [1.06, 0.61, 0.33, 0.16], atol=0.006)
    assert weidmann_speed(0.0) == pytest.approx(1.34) and weidmann_speed(6.0) == 0.0


def test_gamma_is_the_least_squares_fit_to_the_fzj_corridor_runs():
    rho, v = np.array(UG_RUNS).T
    fit = least_squares(lambda p: p[1] * speed_share(rho, p[0]) - v, [1.9, 1.3])
    assert GAMMA == pytest.approx(fit.x[0], abs=0.01)


def test_floor_share_is_one_in_the_open_a_half_at_a_wall_and_erf_in_a_corridor():
    scene = cm.Scene(bounds=([0, 0], [40, 40]), obstacles=[cm.Box([0, 0], [40, 10]), cm.Box([0, 11.8], [40, 40])])
    share = FloorShare(scene)
    open_floor = FloorShare(cm.Scene(bounds=([0, 0], [40, 40])))
    assert open_floor.at(np.array([[20.0, 20.0]]))[0] == pytest.approx(1.0, abs=1e-6)
    # 0.1 m from the bounds' edge (a raster cell's centre): the normal distribution's Φ(0.1 / σ)
    assert open_floor.at(np.array([[20.0, 0.1]]))[0] == pytest.approx(ndtr(0.1 / SIGMA_M), abs=0.01)
    # the middle of a 1.8 m corridor: the kernel's share within ±0.9 m of its centre line
    assert share.at(np.array([[20.0, 10.9]]))[0] == pytest.approx(erf(0.9 / (SIGMA_M * np.sqrt(2))), abs=0.03)


def _corridor_speed(**params):
    scene = open_corridor(1.8, 1.8)
    g = Group("walkers", 200, spawn=Rect([-3.7, 0.3], [7.7, 7.7]), goal=Rect([27, 0.5], [29.5, 7.5]), radius=0.2,
              max_speed=1.8, pref_speed=1.34, attributes={"pref_speed_range": [1.1, 1.58]})
    traj = rvo.simulate(scene, [g], rvo.RVOParams(spawn_gap=0.02, **params), np.random.default_rng(0))
    start, end, _ = stationary(crossing_times(traj, 0, 18.2))
    return area_density_speed(traj, *UO_AREA, start, end)


def test_a_crowd_walking_together_in_a_corridor_slows_to_weidmanns_speed():
    rho, v = _corridor_speed()
    assert 1.0 < rho < 2.0
    assert abs(v - weidmann_speed(rho)) <= 0.15
    # eq. (3) alone lets them keep nearly their free speed at the same density
    rho_off, v_off = _corridor_speed(density_slowing=False, follow=0.0, lane_choice=False)
    assert v_off - weidmann_speed(rho_off) > 0.15


def test_robots_among_people_are_not_slowed_by_the_crowd():
    scene = cm.Scene(bounds=([0, 0], [20, 6]))
    sim = rvo.Simulator(scene)
    people = np.c_[np.linspace(4, 10, 16), np.tile([2.0, 3.0, 4.0, 2.5], 4)]
    sim.add_agents(people, [19, 3], radius=0.2)
    robot = sim.add_agents([[2.0, 3.0]], [[19.0, 3.0]], radius=0.5)
    sim.step()
    assert sim.density[robot[0]] == 0.0 and (sim.density[:16] >= 0).all() and sim.density[:16].max() > 0.5


@pytest.mark.parametrize("their_goal, counted", [([0.0, 3.0], False), ([19.0, 3.0], True)])
def test_a_stream_coming_towards_us_does_not_slow_us_one_going_our_way_does(their_goal, counted):
    # eq. (3) slows a walker for the oncoming (a relative velocity); the slowing density
    # counts those who stand or go its way
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 6])), lane_choice=False)
    walker = sim.add_agents([[2.0, 3.0]], [[19.0, 3.0]], radius=0.2)[0]
    block = np.c_[np.repeat([5.0, 5.6, 6.2, 6.8], 4), np.tile([2.1, 2.7, 3.3, 3.9], 4)]
    sim.add_agents(block, their_goal, radius=0.2)
    sim.velocities[1:] = np.sign(their_goal[0] - 5.0) * np.array([1.3, 0.0])
    sim.step()
    sensing = sim.density_slowing
    assert sensing.density[walker] > 1.0
    if counted:
        assert sensing.density_with[walker] == pytest.approx(sensing.density[walker])
        assert sensing.density_against[walker] == 0.0
    else:
        assert sensing.density_with[walker] == 0.0
        assert sensing.density_against[walker] == pytest.approx(sensing.density[walker])


def _sense_block(wanted_block, their_goal):
    """A walker at (2, 3) bound east for (19, 3) and a block of 16 in front of it (x 5-6.8)
    wanting ``wanted_block``, bound for ``their_goal``: the walker's sensing after one look."""
    scene = cm.Scene(bounds=([-40, -40], [40, 40]))
    sensing = DensitySlowing(scene)
    block = np.c_[np.repeat([5.0, 5.6, 6.2, 6.8], 4), np.tile([2.1, 2.7, 3.3, 3.9], 4)]
    pos = np.r_[[[2.0, 3.0]], block]
    wanted = np.r_[[[1.3, 0.0]], np.tile(wanted_block, (16, 1))]
    goals = np.r_[[[19.0, 3.0]], np.tile(their_goal, (16, 1))]
    radius, active = np.full(17, 0.2), np.ones(17, dtype=bool)
    sensing.grow(17)
    sensing.sense(pos, np.zeros((17, 2)), wanted, radius, active, grid_for(pos, active, radius, np.full(17, 1.5), 0.25),
                  0.25, goals)
    return sensing


@pytest.mark.parametrize("their_goal, against", [([0.0, 3.0], True), ([17.0, 3.5], False), ([5.0, -30.0], True)])
def test_those_who_face_us_count_as_bound_the_other_way_only_if_their_goal_is_not_ours(their_goal, against):
    # a block in front of a walker, all wanting to go west (towards it): with their goal
    # behind the walker they are bound the other way; with their goal beside ours (on their
    # way round a wall to the door we both want) they only face us for a while; with their
    # goal far off to the side they cross our way
    sensing = _sense_block([-1.3, 0.0], their_goal)
    assert sensing.density[0] > 1.0
    assert sensing.density_against[0] == (pytest.approx(sensing.density[0]) if against else 0.0)
    # w is eased in full from AGAINST_FULL_DENSITY on, and not at all with no one bound the other way
    assert sensing.safety_factors(0.15)[0] == pytest.approx(0.15 if against else 1.0)


@pytest.mark.parametrize("their_goal, crossing", [([6.0, 40.0], True), ([11.0, 16.0], False)])
def test_a_stream_crossing_our_way_eases_w_one_converging_on_our_goal_does_not(their_goal, crossing):
    # a block walking north across the walker's way to a goal far off crosses it (w eased as
    # in counterflow); the same block turned 69° off our way for a goal nearer ours (15 m)
    # than the walker is (17 m) is bound where we are: it converges with us
    wanted = np.subtract(their_goal, [5.9, 3.0])
    sensing = _sense_block(1.3 * wanted / np.linalg.norm(wanted), their_goal)
    assert sensing.density[0] > 1.0
    assert sensing.density_against[0] == (pytest.approx(sensing.density[0]) if crossing else 0.0)
    assert sensing.safety_factors(0.15)[0] == pytest.approx(0.15 if crossing else 1.0)


@pytest.mark.parametrize("seed", range(4))
def test_two_streams_crossing_at_right_angles_pass_sooner_with_w_eased_among_crossers(seed):
    # 50 walking east and 50 north through a junction of 6 m corridors: easing w among
    # those crossing our way (as among those coming the other way) shortens the block
    # where the streams meet; counterflow_safety = 1 keeps the full w (nobody here walks
    # against anyone, so it switches off only the crossing's share)
    from crowdmotion.cases import simulate
    from crowdmotion.verify import junction_crossing

    eased, full = (simulate("rvo", junction_crossing("rvo", 50, **params)["junction"], seed).summary
                   for params in ({}, {"counterflow_safety": 1.0}))
    for s in (eased, full):
        assert s["arrival_rate"] == 1.0 and s["agent_agent_overlaps"] == 0
    assert eased["mean_time_to_goal_s"] < full["mean_time_to_goal_s"] - 0.3, (eased, full)
