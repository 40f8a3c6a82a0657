"""Congestion-aware guidance: the distance field re-solved with a cost that grows with
the local density, so a crowd spreads over the width of a corridor instead of every
agent queueing along the shortest line (the inner wall of a corner).

The idea is Treuille, Cooper & Popović's continuum crowds (2006): walking through a cell
costs ``1 + congestion × ρ`` per metre, ρ the density there (agents/m², smoothed over
about a metre). Every ``replan_s`` seconds the field is re-solved on the same
8-connected grid as the exact field (corner cutting off) by scipy's Dijkstra, from all
goal cells at once; agents then aim along it exactly as before. With ``congestion = 0``
the field is the exact distance, unchanged.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from crowdmotion.routing import DistanceFields

SMOOTH_M = 0.75          # density is smoothed with a Gaussian of this many metres
MAX_CELLS = 1_000_000    # larger fields keep the exact distances (re-solving would cost seconds)


class GridGraph:
    """The 8-connected graph of a grid's free cells (diagonals only where both cells beside
    them are free: no corner cutting), edges in metres, for scipy's Dijkstra."""

    def __init__(self, free: np.ndarray, cell: float):
        shape = free.shape
        node = np.full(shape, -1, dtype=np.int64)
        node[free] = np.arange(free.sum())
        self.node = node
        self.cell_index = np.flatnonzero(free.ravel())
        padded = np.pad(free, 1, constant_values=False)

        def at(dx: int, dy: int) -> np.ndarray:  # free[i + dx, j + dy], False off the grid
            return padded[1 + dx:1 + dx + shape[0], 1 + dy:1 + dy + shape[1]]

        src, dst, length = [], [], []
        # each undirected edge once: right, up, and the two diagonals going right
        for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
            ok = free & at(dx, dy)
            if dx and dy:
                ok &= at(dx, 0) & at(0, dy)
            i, j = np.nonzero(ok)
            src.append(node[i, j])
            dst.append(node[i + dx, j + dy])
            length.append(np.full(len(i), np.hypot(dx, dy) * cell))
        self.src, self.dst, self.length = np.concatenate(src), np.concatenate(dst), np.concatenate(length)

    def distances(self, goal_cells: list, shape: tuple, cost: np.ndarray | None = None) -> np.ndarray:
        """(F, nx, ny) least cost from every cell to each field's goal cells (inf where none
        leads); an edge costs its length times the mean ``cost`` of its two cells (per free
        cell, default 1)."""
        w = self.length if cost is None else self.length * 0.5 * (cost[self.src] + cost[self.dst])
        n = len(self.cell_index)
        graph = csr_matrix((w, (self.src, self.dst)), shape=(n, n))
        out = np.full((len(goal_cells),) + tuple(shape), np.inf)
        for k, goals in enumerate(goal_cells):
            goals = np.asarray(goals, dtype=np.int64).reshape(-1, 2)
            d = dijkstra(graph, directed=False, indices=self.node[goals[:, 0], goals[:, 1]], min_only=True)
            out[k].ravel()[self.cell_index] = d
        return out


class CongestionRouter:
    """Re-solves a :class:`DistanceFields` with density-weighted cell costs."""

    def __init__(self, fields: DistanceFields, congestion: float):
        self.fields = fields
        self.congestion = float(congestion)
        free = ~fields.blocked
        self.enabled = self.congestion > 0 and free.size <= MAX_CELLS
        if self.enabled:
            self.graph = GridGraph(free, fields.cell)

    def density(self, positions: np.ndarray) -> np.ndarray:
        """(nx, ny) agents per m² on the field grid, smoothed over ~SMOOTH_M metres."""
        f = self.fields
        shape = f.blocked.shape
        idx = np.floor((positions - f.origin) / f.cell).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < np.array(shape)), axis=1)
        counts = np.zeros(shape)
        np.add.at(counts, (idx[inside, 0], idx[inside, 1]), 1.0)
        return gaussian_filter(counts / f.cell ** 2, SMOOTH_M / f.cell, mode="constant")

    def resolve(self, positions: np.ndarray, exact: np.ndarray) -> np.ndarray:
        """New (F, nx, ny) fields: the weighted distance to each field's goal cells."""
        if not self.enabled or len(positions) == 0:
            return exact
        cost = 1.0 + self.congestion * self.density(positions).ravel()[self.graph.cell_index]
        return self.graph.distances(self.fields.goal_cells, self.fields.blocked.shape, cost)
