"""The stand-off rules compiled (deadlock's numba kernels) decide exactly as the rules
written as numpy array operations (Deadlock.update_numpy), bit for bit."""

import copy

import numpy as np
import pytest

from crowdmotion.rvo import deadlock
from crowdmotion.rvo.deadlock import Deadlock

STATE = ("stuck", "yield_to", "yield_left", "detour", "still", "cornered")


def _crowd(seed: int, n: int = 80):
    """A random jam: agents in a 6 x 6 m square, some standing, some held up for long,
    some yielding or detouring already, half of them bound the other way."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 6, (n, 2))
    heading = np.where(rng.random(n) < 0.5, 0.0, np.pi) + rng.normal(0, 0.4, n)
    heading[rng.random(n) < 0.2] += np.pi / 2  # some cross
    speed = rng.uniform(0.8, 1.5, n)
    wanted = np.stack([np.cos(heading), np.sin(heading)], 1) * speed[:, None]
    wanted[rng.random(n) < 0.05] = 0.0  # some want to stand
    chosen = wanted * rng.choice([0.0, 0.05, 1.0], (n, 1), p=[0.5, 0.2, 0.3])
    active = rng.random(n) < 0.9
    goals = pos + 10 * wanted
    dl = Deadlock(np.deg2rad(15.0), 2.0)
    dl.grow(n)
    dl.stuck = rng.choice([0.0, 1.0, 1.9, 2.0, 3.5], n)
    dl.still = rng.choice([0.0, 2.9, 3.0, 4.0, 5.0], n)
    dl.detour = rng.random(n) < 0.1
    dl.yield_to = np.where(rng.random(n) < 0.1, rng.integers(0, n, n), -1)
    dl.yield_left = rng.uniform(-0.5, 10.0, n)
    sight = rng.choice([1.0, 3.0, 10.0], n)
    dl.cornered = rng.random(n) < 0.1
    return dl, pos, wanted, chosen, speed, np.full(n, 0.25), sight, active, goals


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("with_goals", [True, False])
def test_compiled_update_decides_as_the_numpy_rules(seed, with_goals):
    dl, pos, wanted, chosen, speed, radius, sight, active, goals = _crowd(seed)
    ref = copy.deepcopy(dl)
    goals = goals if with_goals else None
    began = dl.update(pos, wanted, chosen, speed, radius, sight, active, 0.25, goals)
    assert began == ref.update_numpy(pos, wanted, chosen, speed, radius, sight, active, 0.25, goals)
    for name in STATE:
        np.testing.assert_array_equal(getattr(dl, name), getattr(ref, name), err_msg=name)


def test_the_random_jams_exercise_every_rule():
    began = ended = detours = cornered = 0
    for seed in range(20):
        dl, pos, wanted, chosen, speed, radius, sight, active, goals = _crowd(seed)
        yielding = dl.yield_to >= 0
        before, was = dl.detour.copy(), dl.cornered.copy()
        began += dl.update(pos, wanted, chosen, speed, radius, sight, active, 0.25, goals)
        ended += int((yielding & (dl.yield_to < 0)).sum())
        detours += int((dl.detour & ~before).sum())
        cornered += int((dl.cornered & ~was).sum())
    assert began > 0 and ended > 0 and detours > 0 and cornered > 0


def _yielding_velocities_numpy(dl, pos, wanted, pref_speed, radius, active):
    """Deadlock.yielding_velocities written with array operations."""
    d = np.flatnonzero(dl.detour & (dl.yield_to < 0) & active)
    y = np.flatnonzero((dl.yield_to >= 0) & active)
    out = wanted.copy()
    out[d] = deadlock._turn_right(wanted[d], deadlock.DETOUR_TURN)
    j = dl.yield_to[y]
    away = deadlock._turn_right(deadlock._unit(pos[y] - pos[j]), deadlock.YIELD_TURN)
    in_way = deadlock._blocks(pos, wanted, radius, j, y)
    out[y] = np.where(in_way[:, None], away * pref_speed[y, None], 0.0)
    return out


@pytest.mark.parametrize("seed", range(10))
def test_compiled_yielding_velocities_as_the_numpy_rules(seed):
    dl, pos, wanted, _, speed, radius, _, active, _ = _crowd(seed)
    got = dl.yielding_velocities(pos, wanted, speed, radius, active)
    np.testing.assert_array_equal(got, _yielding_velocities_numpy(dl, pos, wanted, speed, radius, active))


def test_nobody_yielding_or_detouring_keeps_v_pref_as_it_is():
    dl, pos, wanted, _, speed, radius, _, active, _ = _crowd(0)
    dl.yield_to[:] = -1
    dl.detour[:] = False
    assert dl.yielding_velocities(pos, wanted, speed, radius, active) is wanted
