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
                        np.full(n, squeeze_s), 0.2, np.zeros(n, dtype=bool), np.zeros(n), np.full(n, np.inf))
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


def _rot(v, a):
    return np.stack([np.cos(a) * v[:, 0] - np.sin(a) * v[:, 1], np.sin(a) * v[:, 0] + np.cos(a) * v[:, 1]], axis=1)


def test_points_ahead_are_the_unit_heading_ahead_of_each_agent():
    rng = np.random.default_rng(3)
    pos, heading = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    heading[8] = 0.0  # standing: senses round itself
    own = np.arange(0, 50, 2)
    centre, head = np.empty((25, 2)), np.empty((25, 2))
    K.points_ahead(pos, heading, own, 3.0, centre, head)
    length = np.linalg.norm(heading[own], axis=1)
    unit = np.where(length[:, None] > 0, heading[own] / np.maximum(length, 1e-300)[:, None], 0.0)
    assert np.allclose(head, unit) and np.allclose(centre, pos[own] + 3.0 * unit)
    assert np.array_equal(head[4], [0.0, 0.0]) and np.array_equal(centre[4], pos[8])


def test_raster_lookup_takes_the_cell_holding_each_point_and_zero_outside():
    rng = np.random.default_rng(4)
    share = rng.random((30, 20))
    pts = rng.uniform(-2.0, 8.0, size=(500, 2))
    out = np.empty(500)
    K.raster_at(share, -1.0, 0.5, 0.25, pts, out)
    ix, iy = np.floor((pts[:, 0] + 1.0) / 0.25).astype(int), np.floor((pts[:, 1] - 0.5) / 0.25).astype(int)
    inside = (ix >= 0) & (ix < 30) & (iy >= 0) & (iy < 20)
    assert 0 < inside.sum() < 500
    assert np.array_equal(out[inside], share[ix[inside], iy[inside]]) and np.all(out[~inside] == 0.0)


def test_lane_turns_are_due_by_turn_by_a_turned_way_or_near_the_goal_and_kept_in_between():
    rng = np.random.default_rng(5)
    n = 40
    vpref, pos = rng.normal(size=(n, 2)), rng.uniform(0, 20, size=(n, 2))
    goals = pos + rng.uniform(-10, 10, size=(n, 2))
    unit = vpref / np.linalg.norm(vpref, axis=1)[:, None]
    heading = _rot(unit, rng.choice([0.1, 0.5], n))  # last choice 6° or 29° off today's way
    heading[:3] = 0.0  # never chose
    active = rng.random(n) > 0.2
    due = np.empty(n, dtype=bool)
    K.lanes_due(vpref, heading, pos, goals, active, 7, 4, np.cos(np.deg2rad(20.0)), 4.0, due)
    turned = np.einsum("ij,ij->i", unit, heading) < np.cos(np.deg2rad(20.0))
    near = np.linalg.norm(goals - pos, axis=1) < 4.0
    assert np.array_equal(due, active & (turned | near | ((np.arange(n) + 7) % 4 == 0)))
    # the due agents record the turn the lane choice gave them; the others turn by the one they keep
    turn = rng.uniform(-0.4, 0.4, n)
    chosen = _rot(vpref, rng.uniform(-0.6, 0.6, n))
    out = chosen.copy()
    new_turn, new_heading = turn.copy(), heading.copy()
    K.lanes_keep(vpref, out, due, active, new_turn, new_heading)
    cross = unit[:, 0] * chosen[:, 1] - unit[:, 1] * chosen[:, 0]
    assert np.allclose(new_turn[due], np.arctan2(cross, np.einsum("ij,ij->i", unit, chosen))[due])
    assert np.allclose(new_heading[due], unit[due]) and np.array_equal(new_heading[~due], heading[~due])
    keep = active & ~due
    assert np.allclose(out[keep], _rot(vpref, turn)[keep]) and np.array_equal(out[~active], chosen[~active])


def test_a_walker_near_its_goal_slows_to_turn_in_at_the_comfortable_acceleration():
    # goal 2 m away, 90° off the velocity: the circle through it has radius d / 2 = 1 m, so
    # at a = 0.8 m/s² the turn allows v = sqrt(a · 1 m)
    pos, goals = np.zeros((3, 2)), np.array([[0.0, 2.0], [10.0, 0.0], [0.0, 2.0]])
    vel = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    vpref = np.array([[0.0, 1.3], [1.3, 0.0], [0.0, 1.3]])
    radius = np.array([0.25, 0.25, 0.6])  # the last is no person: it keeps its v_pref
    out = np.empty((3, 2))
    K.turned_in(vpref, goals, pos, vel, radius, 0.4, 0.8, out)
    assert np.allclose(out[0], [0.0, np.sqrt(0.8)])
    assert np.allclose(out[1], vpref[1]) and np.allclose(out[2], vpref[2])  # heading for it / a robot
