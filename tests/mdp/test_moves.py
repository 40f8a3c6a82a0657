"""The move tables: the successor pruning the fast solver relies on is sound."""

import numpy as np
import pytest

from crowdmotion.mdp.moves import move_costs, move_offsets, successor_moves


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
