"""Lane choice (rvo.lanes): walkers turn towards the clearest way ahead."""

import numpy as np

from crowdmotion.obstacle_primitives import ObstacleSet
from crowdmotion._contact import grid_for
from crowdmotion.rvo.lanes import lane_velocities
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


def test_a_walker_chooses_its_lane_every_half_second_and_keeps_its_turn_between():
    from crowdmotion.rvo.lanes import LaneChoice

    lanes = LaneChoice(0.25)
    lanes.grow(7)
    assert lanes.period == 2 and LaneChoice(1 / 60).period == 30 and LaneChoice(0.5).period == 1
    straight = np.array([1.3, 0.0])
    turned = _choices(lanes, True, straight)  # step 0: agent 0's turn to choose
    assert turned[1] < -0.1
    # step 1: the column is gone, and the way has turned 10° left: the walker keeps its turn
    way = 1.3 * np.array([np.cos(0.17), np.sin(0.17)])
    kept = _choices(lanes, False, way)
    assert np.isclose(_angle(kept, way), _angle(turned, straight))
    assert np.isclose(np.linalg.norm(kept), 1.3)
    assert np.allclose(_choices(lanes, False, way), way)  # step 2: it chooses again: nobody ahead


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
