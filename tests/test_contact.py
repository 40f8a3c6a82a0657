"""Shared contact kernels against closed forms: times to collision with discs and wall
segments, the obstacle safety pass."""

import numpy as np
import pytest

from crowdmotion import _contact as K


def test_ray_disc_head_on_and_miss():
    # from x = -10 at 1 m/s toward a disc of radius 1 at the origin: contact at t = 9
    assert K._ray_disc(-10.0, 0.0, 1.0, 0.0, 1.0) == pytest.approx(9.0)
    # offset by 0.6: contact where x = -sqrt(1 - 0.36) = -0.8, t = 9.2
    assert K._ray_disc(-10.0, 0.6, 1.0, 0.0, 1.0) == pytest.approx(10 - 0.8)
    assert K._ray_disc(-10.0, 1.5, 1.0, 0.0, 1.0) == np.inf  # passes by
    assert K._ray_disc(-10.0, 0.0, -1.0, 0.0, 1.0) == np.inf  # moving away
    assert K._ray_disc(0.5, 0.0, 1.0, 0.0, 1.0) == 0.0  # already inside


def test_ray_capsule_face_end_and_parallel():
    # body r = 0.5 falling onto the segment (-1,0)-(1,0) from y = 2 at 1 m/s: t = 1.5
    assert K._ray_capsule(0.0, 2.0, 0.0, -1.0, -1.0, 0.0, 1.0, 0.0, 0.5) == pytest.approx(1.5)
    # approaching the end point (1, 0) along the axis from x = 4: t = 4 - 1 - 0.5
    assert K._ray_capsule(4.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.5) == pytest.approx(2.5)
    # moving parallel 0.6 above the segment never touches
    assert K._ray_capsule(-3.0, 0.6, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.5) == np.inf
    # brushing the end cap: passes at height 0.3 beyond the end -> hits the rounded cap
    t = K._ray_capsule(1.2, 3.0, 0.0, -1.0, -1.0, 0.0, 1.0, 0.0, 0.5)
    assert t == pytest.approx(3.0 - np.sqrt(0.25 - 0.04))
    # within r of the segment's line but beyond its end, walking away: it never touches
    # (a negative time here once ruled out every move away from a wall's end)
    assert K._ray_capsule(3.0, 0.3, 0.0, -1.0, -1.0, 0.0, 1.0, 0.0, 0.5) == np.inf
    assert K._ray_capsule(3.0, -0.3, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.5) == np.inf
    # ... and walking towards the end, it meets the end cap: from x = 3 at height 0.3
    assert K._ray_capsule(3.0, 0.3, -1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.5) == pytest.approx(2.0 - 0.4)


def test_obstacle_safe_moves_stops_short_of_a_disc_and_a_moving_wall():
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    vel = np.array([[2.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    radius = np.full(3, 0.5)
    # disc of radius 1 at x = 2.2: agent 0 touches at x = 0.7 (t = 0.35 s) in a 1 s step
    circ_c, circ_r, circ_v = np.array([[2.2, 0.0]]), np.array([1.0]), np.zeros((1, 2))
    # a wall at y = 2.2 moving down at 1 m/s, agent 2 climbing at 1 m/s
    seg_a, seg_b, seg_v = np.array([[19.0, 2.2]]), np.array([[21.0, 2.2]]), np.array([[0.0, -1.0]])
    scale = np.zeros(3)
    K.obstacle_safe_moves(pos, vel, radius, np.full(3, 2.0), np.ones(3, bool), 1.0, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v,
                          scale)
    # head on there is nothing to slide along: halved to 0.5 m < 0.7 m (1 m would touch)
    assert scale[0] == 0.25 and vel[0, 0] == pytest.approx(0.5)
    assert scale[1] == 1.0  # nothing ahead of agent 1
    # gap 1.7 m closing at 1 + s m/s: s = 1 touches after 0.85 s, s = 0.5 keeps clear (1.13 s)
    assert scale[2] == 0.5 and vel[2, 1] == pytest.approx(0.5)


def test_obstacle_safe_moves_slides_along_a_wall():
    # 0.6 m below a wall y = 1 (body r = 0.5), moving diagonally up-right: the climb is
    # taken away and the agent slides along the wall at full horizontal speed
    pos, vel = np.array([[0.0, 0.4]]), np.array([[1.0, 1.0]])
    scale = np.zeros(1)
    K.obstacle_safe_moves(pos, vel, np.array([0.5]), np.array([2.0]), np.ones(1, bool), 1.0, np.zeros((0, 2)), np.zeros(0),
                          np.zeros((0, 2)), np.array([[-5.0, 1.0]]), np.array([[5.0, 1.0]]), np.zeros((1, 2)), scale)
    assert vel[0] == pytest.approx([1.0, 0.0])
    assert scale[0] == pytest.approx(1 / np.sqrt(2))


def test_obstacle_safe_moves_flees_a_disc_that_would_run_it_over():
    # a disc (r = 1) 2 m behind, coming at 1.5 m/s: standing is hit within the 1 s step
    pos, vel = np.array([[0.0, 0.0]]), np.array([[0.0, 0.0]])
    K.obstacle_safe_moves(pos, vel, np.array([0.5]), np.array([2.0]), np.ones(1, bool), 1.0,
                          np.array([[-2.0, 0.0]]), np.array([1.0]), np.array([[1.5, 0.0]]), np.zeros((0, 2)),
                          np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(1))
    assert np.linalg.norm(vel[0]) == pytest.approx(2.0)
    assert K._ray_disc(2.0, 0.0, vel[0, 0] - 1.5, vel[0, 1], 1.5) >= 1.0  # the flight keeps clear
