"""The move tables: the successor pruning the fast solver relies on is sound; the crossing
table against closest approach computed here."""

from itertools import product

import numpy as np
import pytest

from crowdmotion.mdp.moves import crossing_masks, move_costs, move_offsets, successor_moves


@pytest.mark.parametrize("dim,counts", [(2, {3, 5}), (3, {9, 15, 19})])
def test_successor_moves_drop_exactly_the_moves_a_parent_already_offered(dim, counts):
    offs, costs = move_offsets(dim), move_costs(dim)
    table, count = successor_moves(dim)
    assert set(count.tolist()) == counts
    for a in range(len(offs)):
        kept = set(table[a, : count[a]].tolist())
        for b in range(len(offs)):
            total = offs[a] + offs[b]
            direct = float(np.linalg.norm(total))  # the parent's own move to that cell, or 0
            if b in kept:
                assert np.abs(total).max() == 2  # not a neighbour of the parent
            else:
                assert np.abs(total).max() <= 1
                # strictly shorter straight from the parent, by a wide margin (TIE is 1e-6)
                assert direct < costs[a] + costs[b] - 0.58


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("sep", [0.7071, 0.5, 1.0])
def test_crossing_masks_match_closest_approach_computed_here(dim, sep):
    near = np.array(list(product(range(-2, 3), repeat=dim)), dtype=np.float64)
    moves = move_offsets(dim).astype(np.float64)
    masks = crossing_masks(near, moves, sep**2)
    disp = np.vstack([moves, np.zeros((1, dim))])  # the other agent's move, or staying
    # the gap between own path t*own and the other's r + t*other, sampled over the step
    t = np.linspace(0.0, 1.0, 401)[:, None]
    rel = disp[:, None, :] - moves[None, :, :]  # (other, own, dim)
    for q, r in enumerate(near):
        pts = r + t[:, None, None, :] * rel[None]  # (t, other, own, dim)
        gap = np.linalg.norm(pts, axis=-1).min(axis=0)
        bits = (masks[q][:, None] >> np.arange(len(moves))[None, :]) & 1
        clear = np.abs(gap - sep) > 1e-2  # away from the threshold sampling is exact enough
        np.testing.assert_array_equal(bits[clear] == 1, (gap < sep)[clear])
