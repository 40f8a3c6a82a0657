"""Attraction-point mesh guidance (§3.2): each agent follows a vertex of its group's mesh;
an agent farther than L from its vertex is dislocated, releases it and heads for the
nearest unoccupied vertex, eqs. (3)–(4), choosing again whenever that vertex is taken."""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

CANDIDATES = 8
REBALANCE_MAX = 4000


def attraction_magnitude(distance, attraction_radius: float, radius) -> np.ndarray:
    """Eq. (4): f = 1/(R − r − l) − 1/(R − r); infinite from l ≥ R − r on."""
    gap = attraction_radius - np.asarray(radius, float)
    l = np.asarray(distance, float)
    with np.errstate(divide="ignore"):
        return np.where(l < gap, 1.0 / np.maximum(gap - l, 1e-300) - 1.0 / gap, np.inf)


def attraction_force(agents: np.ndarray, points: np.ndarray, attraction_radius: float, radius) -> np.ndarray:
    """Eq. (3): F_o = f · (a(o) − o)/‖a(o) − o‖ for agents (k, 2) and their points (k, 2)."""
    d = points - agents
    l = np.linalg.norm(d, axis=1)
    unit = np.divide(d, l[:, None], out=np.zeros_like(d), where=l[:, None] > 0)
    f = np.minimum(attraction_magnitude(l, attraction_radius, radius), 1e300)  # beyond R − r: unbounded
    return f[:, None] * unit


@njit(cache=True)
def claim_vertices(order, cand, taken, out):
    """Agents in ``order`` each take their first candidate vertex (row of ``cand``, nearest
    first, −1 padding) not yet ``taken``; ``out`` gets the vertex or −1 if all were taken."""
    for s in range(order.shape[0]):
        a = order[s]
        out[a] = -1
        for k in range(cand.shape[1]):
            v = cand[a, k]
            if v >= 0 and not taken[v]:
                taken[v] = True
                out[a] = v
                break


class AttractionGuide:
    """Which vertex each of a group's agents follows, and who is dislocated.

    ``assignment[a]`` is agent a's vertex (a permutation: there are as many vertices as
    agents). With ``reassign=False`` it never changes (traditional mesh guidance).
    """

    def __init__(self, n: int, occupy_distance: float, reassign: bool = True):
        self.assignment = np.arange(n, dtype=np.int64)
        self.L = float(occupy_distance)
        self.reassign = bool(reassign)
        self.dislocated = np.zeros(n, dtype=bool)
        self.dislocations = 0  # agents that became dislocated, summed over steps
        self.reassignments = 0  # times an agent changed vertex

    def update(self, agents: np.ndarray, vertices: np.ndarray, hold: bool = False) -> np.ndarray:
        """Mark dislocated agents (farther than L from their vertex) and, with reassignment
        (and not ``hold``), give each the nearest vertex no other agent occupies or has
        just claimed.

        Only dislocated agents are searched, among the free vertices only (a k-d tree of
        them; an agent whose candidates were all claimed asks for more).
        Returns the dislocated mask.
        """
        d = np.linalg.norm(agents - vertices[self.assignment], axis=1)
        now = d >= self.L
        self.dislocations += int((now & ~self.dislocated).sum())
        self.dislocated = now
        if not self.reassign or hold or not now.any():
            return now
        lost = np.flatnonzero(now)
        taken = np.zeros(len(vertices), dtype=bool)
        taken[self.assignment[~now]] = True
        free = np.flatnonzero(~taken)  # as many as the dislocated agents: a small tree
        tree = cKDTree(vertices[free])
        chosen = np.full(len(agents), -1, np.int64)
        who, k = lost, min(CANDIDATES, len(free))
        while len(who):  # the nearest free vertices first; those who found all taken ask for more
            dist, j = tree.query(agents[who], k=k)
            dist, j = dist.reshape(len(who), k), j.reshape(len(who), k)
            cand = np.full((len(agents), k), -1, np.int64)
            cand[who] = free[j]
            claim_vertices(who[np.argsort(dist[:, 0], kind="stable")], cand, taken, chosen)
            if k == len(free) and (chosen[who] < 0).any():  # pragma: no cover - cannot happen
                raise RuntimeError("attraction points: more dislocated agents than free vertices")
            who, k = who[chosen[who] < 0], min(len(free), max(k, len(who)))
        changed = chosen[lost] != self.assignment[lost]
        self.reassignments += int(changed.sum())
        self.assignment[lost] = chosen[lost]
        return now

    def rebalance(self, agents: np.ndarray, vertices: np.ndarray) -> int:
        """Give every agent a vertex so that the summed squared distance is least (scipy's
        linear_sum_assignment). Used in the target area, where agents left behind the
        formation could otherwise not get past its back rank to the free vertices inside:
        everyone shifts up by one place instead. Groups above ``REBALANCE_MAX`` agents
        are left as they are (the dense problem would cost too much). Returns how many
        agents changed vertex."""
        n = len(agents)
        if n > REBALANCE_MAX:
            return 0
        cost = np.sum((agents[:, None, :] - vertices[None, :, :]) ** 2, axis=-1)
        _, col = linear_sum_assignment(cost)
        changed = int((col != self.assignment).sum())
        self.reassignments += changed
        self.assignment = np.asarray(col, np.int64)
        return changed

    @property
    def slot_order(self) -> np.ndarray:
        """Agent at each vertex (the inverse permutation)."""
        inv = np.empty_like(self.assignment)
        inv[self.assignment] = np.arange(len(self.assignment))
        return inv
