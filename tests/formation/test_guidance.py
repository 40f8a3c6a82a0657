"""Attraction-point guidance: eqs. (3)-(4), dislocation, nearest free vertex, rebalancing."""

import itertools

import numpy as np
import pytest

from crowdmotion.formation.guidance import AttractionGuide, attraction_force, attraction_magnitude


def test_attraction_force_eqs_3_and_4():
    R, r = 10.0, 0.5
    assert attraction_magnitude(0.0, R, r) == 0.0
    assert attraction_magnitude(2.0, R, r) == pytest.approx(1 / (9.5 - 2) - 1 / 9.5)
    assert attraction_magnitude(9.5, R, r) == np.inf
    F = attraction_force(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]]), R, r)
    assert F[0] == pytest.approx((1 / 4.5 - 1 / 9.5) * np.array([0.6, 0.8]))


def test_agents_within_L_occupy_their_vertex_and_the_others_take_the_nearest_free_one():
    vertices = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    guide = AttractionGuide(4, occupy_distance=0.5)
    # agent 1 was knocked off beyond vertex 3; agent 3 drifted toward vertex 1
    agents = np.array([[0.1, 0.0], [3.3, 1.0], [2.0, 0.2], [1.2, 1.0]])
    lost = guide.update(agents, vertices)
    assert lost.tolist() == [False, True, False, True]
    assert guide.assignment.tolist() == [0, 3, 2, 1]  # each took the nearest free vertex
    assert guide.dislocations == 2 and guide.reassignments == 2


def test_a_taken_vertex_goes_to_the_nearer_agent_and_the_other_picks_again():
    vertices = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]])
    guide = AttractionGuide(3, occupy_distance=0.5)
    agents = np.array([[0.0, 0.0], [4.0, 1.0], [4.5, 0.9]])  # agents 1, 2 both nearest vertex 1
    guide.update(agents, vertices)
    assert guide.assignment[2] == 1 and guide.assignment[1] == 2


def test_without_reassignment_agents_keep_their_vertex():
    guide = AttractionGuide(2, occupy_distance=0.5, reassign=False)
    lost = guide.update(np.array([[5.0, 0.0], [0.0, 0.0]]), np.array([[0.0, 0.0], [5.0, 0.0]]))
    assert lost.all() and guide.assignment.tolist() == [0, 1]


def test_rebalance_finds_the_least_total_squared_distance():
    rng = np.random.default_rng(1)
    agents, vertices = rng.uniform(0, 5, (6, 2)), rng.uniform(0, 5, (6, 2))
    guide = AttractionGuide(6, 0.5)
    guide.rebalance(agents, vertices)
    cost = lambda perm: np.sum((agents - vertices[list(perm)]) ** 2)  # noqa: E731
    best = min(itertools.permutations(range(6)), key=cost)
    assert cost(guide.assignment) == pytest.approx(cost(best))
    assert sorted(guide.slot_order.tolist()) == list(range(6))
