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
