"""Lane choice (rvo.lanes): walkers turn towards the clearest way ahead."""

import numpy as np

from crowdmotion.obstacle_primitives import ObstacleSet
from crowdmotion._contact import grid_for
from crowdmotion.rvo.lanes import (AIM_M, CROWD_WEIGHT, FULL_DENSITY, LOOK_M, MIN_PRESSURE, OFFSETS_M, RIGHT_BONUS,
                                   SAFETY_REFERENCE, SIDE_COST, SPREAD_M, lane_velocities)
from crowdmotion.scene import Scene

SCENE = Scene(bounds=([-20, -20], [20, 20]))


def _turn(others, other_vpref, other_vel=None, density=2.0):
    """v_pref of a walker at the origin heading +x at 1.3 m/s among ``others``."""
    pos = np.vstack([[0.0, 0.0], others])
    n = len(pos)
    vpref = np.vstack([[1.3, 0.0], other_vpref])
    vel = vpref.copy() if other_vel is None else np.vstack([[1.3, 0.0], other_vel])
    radius, active = np.full(n, 0.2), np.ones(n, dtype=bool)
    grid = grid_for(pos, active, radius, np.full(n, 1.8), 0.25)
    out = lane_velocities(pos, vel, vpref, radius, np.full(n, 5.0), np.full(n, density), active, grid,
                          ObstacleSet(SCENE).at(0.0, 0.25))
    return out[0]


def test_a_walker_alone_keeps_its_way():
    assert np.allclose(_turn(np.zeros((0, 2)), np.zeros((0, 2))), [1.3, 0.0])


def test_a_walker_facing_an_oncoming_column_turns_right_and_keeps_its_speed():
    column = np.c_[np.arange(1.5, 6.0, 0.75), np.zeros(6)]
    v = _turn(column, np.tile([-1.3, 0.0], (6, 1)))
    assert v[1] < -0.1 and v[0] > 0 and np.linalg.norm(v) == np.float64(np.linalg.norm([1.3, 0.0]))


def test_oncoming_walkers_on_the_right_send_it_left():
    # right of a walker heading +x is -y
    column = np.c_[np.arange(1.5, 6.0, 0.75), np.full(6, -0.6)]
    v = _turn(column, np.tile([-1.3, 0.0], (6, 1)))
    assert v[1] > 0.1


def test_a_walker_ahead_at_our_pace_is_followed_and_one_standing_is_passed():
    ahead = np.array([[1.5, 0.0], [2.3, 0.0], [3.1, 0.0]])
    walking = _turn(ahead, np.tile([1.3, 0.0], (3, 1)))
    standing = _turn(ahead, np.tile([1.3, 0.0], (3, 1)), other_vel=np.zeros((3, 2)))
    assert np.allclose(walking, [1.3, 0.0]) and abs(standing[1]) > 0.1


def test_in_the_open_the_term_rests():
    column = np.c_[np.arange(1.5, 6.0, 0.75), np.zeros(6)]
    assert np.allclose(_turn(column, np.tile([-1.3, 0.0], (6, 1)), density=0.0), [1.3, 0.0])


def _choices(lanes, column, vpref0, goal0=(50.0, 0.0)):
    """One step of ``lanes`` (a LaneChoice) for a walker at the origin with v_pref
    ``vpref0`` and, if ``column``, an oncoming column straight ahead; its v_pref out."""
    others = np.c_[np.arange(1.5, 6.0, 0.75), np.zeros(6)] if column else np.array([[-15.0, 15.0]] * 6)
    others = others + np.arange(6)[:, None] * [0.0, 1e-3]  # distinct points
    pos = np.vstack([[0.0, 0.0], others])
    n = len(pos)
    vpref = np.vstack([vpref0, np.tile([-1.3, 0.0], (6, 1))])
    radius, active = np.full(n, 0.2), np.ones(n, dtype=bool)
    goals = np.vstack([goal0, np.tile([-50.0, 0.0], (6, 1))])
    grid = grid_for(pos, active, radius, np.full(n, 1.8), 0.25)
    return lanes.velocities(pos, vpref.copy(), vpref, radius, np.full(n, 5.0), np.full(n, 2.0), active, grid,
                            ObstacleSet(SCENE).at(0.0, 0.25), goals)[0]


def _angle(v, w) -> float:
    return float(np.arctan2(w[0] * v[1] - w[1] * v[0], w @ v))


def test_a_walker_chooses_its_lane_every_second_and_keeps_its_turn_between():
    from crowdmotion.rvo.lanes import LaneChoice

    lanes = LaneChoice(0.25)
    lanes.grow(7)
    assert lanes.period == 4 and LaneChoice(1 / 60).period == 60 and LaneChoice(1.0).period == 1
    straight = np.array([1.3, 0.0])
    turned = _choices(lanes, True, straight)  # step 0: agent 0's turn to choose
    assert turned[1] < -0.1
    # steps 1-3: the column is gone, and the way has turned 10° left: the walker keeps its turn
    way = 1.3 * np.array([np.cos(0.17), np.sin(0.17)])
    for _ in range(3):
        kept = _choices(lanes, False, way)
        assert np.isclose(_angle(kept, way), _angle(turned, straight))
        assert np.isclose(np.linalg.norm(kept), 1.3)
    assert np.allclose(_choices(lanes, False, way), way)  # step 4: it chooses again: nobody ahead


def test_a_walker_chooses_again_at_once_when_its_way_turns_or_its_goal_is_near():
    from crowdmotion.rvo.lanes import NEAR_GOAL_M, LaneChoice

    straight = np.array([1.3, 0.0])
    for second, goal in (((1.3 * np.cos(0.5), 1.3 * np.sin(0.5)), (50.0, 0.0)),  # way turned 29°
                         (straight, (NEAR_GOAL_M - 0.5, 0.0))):  # its goal in reach
        lanes = LaneChoice(0.25)
        lanes.grow(7)
        _choices(lanes, True, straight, goal)
        assert np.allclose(_choices(lanes, False, np.array(second), goal), second)
    # placed elsewhere or given a new goal (forget): it chooses at its next step
    lanes = LaneChoice(0.25)
    lanes.grow(7)
    _choices(lanes, True, straight)
    lanes.forget(np.array([0]))
    assert np.allclose(_choices(lanes, False, straight), straight)


def _reference_costs(pos, vel, vpref, weight):
    """The module docstring's cost of every offset for every walker, evaluated directly in
    numpy: every neighbour at every offset (no lattice factoring, nothing left out)."""
    sp = np.linalg.norm(vpref, axis=1)
    u = vpref / sp[:, None]
    right = np.c_[u[:, 1], -u[:, 0]]
    d = pos[None] - pos[:, None]                       # d[i, j] = p_j − p_i
    ahead, lat = np.einsum("ijk,ik->ij", d, u), np.einsum("ijk,ik->ij", d, right)
    oncoming = np.einsum("jk,ik->ij", vpref, u) < -0.5 * np.linalg.norm(vpref, axis=1)[None]
    lag = 1.0 - np.einsum("jk,ik->ij", vel, u) / sp[:, None]
    share = np.where(oncoming, 1.0, CROWD_WEIGHT * np.clip(lag, 0.0, 1.0))
    counted = (ahead > 0) & (ahead <= LOOK_M) & ~np.eye(len(pos), dtype=bool)
    w = np.where(counted, share * np.exp(-2.0 * ahead / LOOK_M), 0.0)
    g = np.exp(-(lat[..., None] - OFFSETS_M) ** 2 / (2 * SPREAD_M ** 2))  # (i, j, offset)
    pressure = weight[:, None] * np.einsum("ij,ijk->ik", w, g)
    return pressure + SIDE_COST * np.abs(OFFSETS_M) - RIGHT_BONUS * OFFSETS_M, pressure[:, 0] >= MIN_PRESSURE


def test_the_kernel_chooses_the_offset_the_formula_gives():
    # the kernel factors each neighbour's Gaussian over the 0.3 m lattice of offsets and
    # leaves out neighbours too far aside to matter: against the formula summed in full,
    # every walker turns to the offset of least cost, or to one costing at most 1e-3 more
    rng = np.random.default_rng(3)
    n = 300
    pos = rng.uniform(-8, 8, (n, 2))
    ang = np.where(rng.random(n) < 0.5, 0.0, np.pi) + rng.normal(0, 0.3, n)
    vpref = 1.3 * np.c_[np.cos(ang), np.sin(ang)]
    vel = vpref * rng.uniform(0, 1.2, (n, 1))
    radius, active = np.full(n, 0.2), np.ones(n, dtype=bool)
    safety, density = rng.uniform(2, 8, n), rng.uniform(0.3, 2.0, n)
    grid = grid_for(pos, active, radius, np.full(n, 1.8), 0.25)
    out = lane_velocities(pos, vel, vpref, radius, safety, density, active, grid,
                          ObstacleSet(Scene(bounds=([-30, -30], [30, 30]))).at(0.0, 0.25))
    costs, turns = _reference_costs(pos, vel, vpref, safety / SAFETY_REFERENCE * np.minimum(density / FULL_DENSITY, 1))
    u = vpref / np.linalg.norm(vpref, axis=1)[:, None]
    # the offset each walker turned to, read back from its turned v_pref
    along, aside = np.einsum("ij,ij->i", out, u), out[:, 0] * u[:, 1] - out[:, 1] * u[:, 0]
    chosen = np.argmin(np.abs(AIM_M * aside / along - OFFSETS_M[:, None]).T, axis=1)
    assert np.allclose(np.linalg.norm(out, axis=1), 1.3)
    assert (chosen[~turns] == 0).all()  # nobody in the way straight on: v_pref kept
    picked = costs[np.arange(n), chosen]
    assert turns.sum() > 100 and (chosen[turns] != 0).sum() > 30  # the scene makes most of them weigh a turn
    assert np.all(picked[turns] <= costs[turns].min(axis=1) + 1e-3)
