"""RVO kernels against closed forms and scipy: k nearest neighbours, the velocity choice."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from crowdmotion.rvo import _kernels as K


@pytest.mark.parametrize("m,dmax", [(1, 100.0), (5, 3.0), (10, 1.0), (20, 50.0)])
def test_knn_matches_ckdtree(m, dmax):
    rng = np.random.default_rng(m)
    pos = rng.uniform(0, 30, size=(400, 2))
    active = rng.random(400) > 0.1
    h = 1.7
    lo = pos[active].min(axis=0)
    nx, ny = (np.floor((pos[active].max(axis=0) - lo) / h) + 1).astype(int)
    start, items = K.build_grid(pos, active, lo[0], lo[1], h, nx, ny)
    live = np.flatnonzero(active)
    tree = cKDTree(pos[live])
    idx = np.empty(m, dtype=np.int64)
    d2 = np.empty(m)
    for i in live[:60]:
        k = K._knn(i, pos, m, dmax, start, items, lo[0], lo[1], h, nx, ny, idx, d2)
        dd, jj = tree.query(pos[i], k=m + 1, distance_upper_bound=dmax)
        ref = [(d, live[j]) for d, j in zip(np.atleast_1d(dd), np.atleast_1d(jj)) if np.isfinite(d) and live[j] != i][:m]
        assert k == len(ref)
        assert np.allclose(np.sqrt(d2[:k]), [d for d, _ in ref])


def _choose(pos, vel, vpref, samples=20, safety=5.0, segs=None, comfort=0.0, goals=None, leave_r=0.0,
            squeeze_s=np.inf):
    n = len(pos)
    active = np.ones(n, dtype=bool)
    h = 5.0
    lo = pos.min(axis=0)
    nx, ny = (np.floor((pos.max(axis=0) - lo) / h) + 1).astype(int)
    start, items = K.build_grid(pos, active, lo[0], lo[1], h, nx, ny)
    seg_a = np.zeros((0, 2)) if segs is None else segs[0]
    seg_b = np.zeros((0, 2)) if segs is None else segs[1]
    out = np.zeros((n, 2))
    K.choose_velocities(pos, vel, vpref, np.full(n, 100.0), np.full(n, 0.5), np.full(n, 1.5), np.full(n, 10),
                        np.full(n, 10.0), np.full(n, samples), np.full(n, safety), active, start, items,
                        lo[0], lo[1], h, nx, ny, np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), seg_a, seg_b,
                        np.zeros_like(seg_a), 0.25, np.uint64(7), out, np.zeros(n, dtype=bool), 0.0, 5.0, np.zeros(n),
                        np.full(n, comfort), pos + 100.0 if goals is None else goals, np.full(n, leave_r),
                        np.full(n, squeeze_s), 0.2)
    return out


def test_lone_agent_takes_its_preferred_velocity():
    out = _choose(np.array([[0.0, 0.0]]), np.zeros((1, 2)), np.array([[1.2, 0.3]]))
    assert np.allclose(out[0], [1.2, 0.3])


def test_wall_ahead_within_the_step_is_never_chosen():
    # a wall 0.6 m ahead of a body of radius 0.5: v_pref of 1.3 m/s would reach it in 0.077 s
    segs = (np.array([[0.6, -5.0]]), np.array([[0.6, 5.0]]))
    out = _choose(np.array([[0.0, 0.0]]), np.zeros((1, 2)), np.array([[1.3, 0.0]]), samples=200, segs=segs)
    assert out[0, 0] * 0.25 <= 0.1 + 1e-9


def test_from_rest_a_lone_walker_changes_its_velocity_only_comfortably():
    # the comfortable change this step is 0.2 m/s: the choice is that far towards v_pref
    vpref = np.array([[1.2, 0.3]])
    out = _choose(np.array([[0.0, 0.0]]), np.zeros((1, 2)), vpref, comfort=0.2)
    assert np.allclose(out[0], 0.2 * vpref[0] / np.linalg.norm(vpref[0]))


def test_a_harder_change_is_taken_when_the_comfortable_ones_lead_into_a_neighbour():
    # walking at 1.3 m/s onto one standing 1 m ahead (bodies of 0.5 m): every 0.2 m/s change
    # still meets it within about a second, so the walker brakes or swerves harder
    pos = np.array([[0.0, 0.0], [2.0, 0.0]])
    vel = np.array([[1.3, 0.0], [0.0, 0.0]])
    vpref = np.array([[1.3, 0.0], [0.0, 0.0]])
    out = _choose(pos, vel, vpref, samples=200, comfort=0.2)
    assert np.linalg.norm(out[0] - vel[0]) > 0.2 + 1e-9


def test_an_agent_about_to_leave_steps_in_past_a_neighbour_beyond_its_goal():
    # agent 0 is 0.7 m from the goal point it leaves at (within 0.5 m); agent 1, bound for
    # the same point, comes from 1.25 m beyond it: eq. (3) alone turns 0 aside short of the
    # arrival disc, but the collision it fears would come only after 0 has left
    pos = np.array([[0.0, 0.0], [1.95, 0.0]])
    vel = np.array([[1.0, 0.0], [-0.5, 0.0]])
    vpref = np.array([[1.3, 0.0], [-1.3, 0.0]])
    goals = np.array([[0.7, 0.0], [0.7, 0.0]])
    stays = _choose(pos, vel, vpref, samples=50, goals=goals, leave_r=0.0)
    leaves = _choose(pos, vel, vpref, samples=50, goals=goals, leave_r=0.5)
    assert np.linalg.norm(pos[0] + stays[0] * 0.25 - goals[0]) > 0.5
    assert np.linalg.norm(pos[0] + leaves[0] * 0.25 - goals[0]) <= 0.5
    assert np.allclose(leaves[0], vpref[0])


def test_a_walker_squeezes_past_one_bound_the_other_way_but_not_one_bound_its_way():
    # a 1.2 m corridor (walls y = 0 and 1.2): two walkers head-on, 0.1 m apart sideways
    segs = (np.array([[-10.0, 0.0], [-10.0, 1.2]]), np.array([[10.0, 0.0], [10.0, 1.2]]))
    pos = np.array([[0.0, 0.55], [2.0, 0.65]])
    vel = np.zeros((2, 2))
    vpref = np.array([[1.3, 0.0], [-1.3, 0.0]])
    opposed = np.array([[9.0, 0.55], [-9.0, 0.65]])
    plain = _choose(pos, vel, vpref, samples=200, segs=segs, goals=opposed)
    squeeze = _choose(pos, vel, vpref, samples=200, segs=segs, goals=opposed, squeeze_s=0.5)
    # eq. (3) alone has both stand (any way round the other drifts towards a wall, priced
    # w * v_perp / gap); squeezing past, both move off the line, each to the same side of its way
    assert np.all(plain == 0.0)
    assert np.all(np.linalg.norm(squeeze, axis=1) > 0.2) and squeeze[0, 1] * squeeze[1, 1] < 0.0
    # two converging on one door (their goals the same place) come towards each other too,
    # but bound the same way: walls count as eq. (3) has them
    door = np.array([[1.0, -5.0], [1.0, -5.0]])
    same = _choose(pos, vel, vpref, samples=200, segs=segs, goals=door, squeeze_s=0.5)
    np.testing.assert_array_equal(same, _choose(pos, vel, vpref, samples=200, segs=segs, goals=door))
