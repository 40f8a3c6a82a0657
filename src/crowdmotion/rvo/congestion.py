"""Congestion-aware guidance: the distance field re-solved with a cost that grows with
the local density, so a crowd spreads over the width of a corridor instead of every
agent queueing along the shortest line (the inner wall of a corner).

The idea is Treuille, Cooper & Popović's continuum crowds (2006): walking through a cell
costs ``1 + congestion × ρ`` per metre, ρ the density there (agents/m², smoothed over
about a metre). Every ``replan_s`` seconds the field is re-solved on the same
8-connected grid as the exact field (corner cutting off) by scipy's Dijkstra, from all
goal cells at once; agents then aim along it exactly as before. With several goal
regions and steps shorter than a quarter second (a game's frames), the costs are taken
from the crowd at the period's first step and the fields' Dijkstras spread over the
steps of its first quarter second, the new fields taken together (the simulator's
``_replan``): a 12-region square at 60 fps steps in at most 9 ms instead of 30 ms.
With ``congestion = 0`` and ``counterflow = 0`` the field is the exact distance,
unchanged.

Walking against the crowd's flow (``counterflow > 0``, default 20) costs more on top:
continuum crowds take the speed a crowd allows in a direction from the flow there, so
that a cell where everyone walks towards you is slow to cross in your direction and fast
in theirs. Here a move in direction n̂ costs, per metre,

    1 + congestion · ρ + counterflow · max(0, −J · n̂)

with J the crowd's flux (Σ of the agents' velocities per m², smoothed as ρ is; persons
per metre per second). In a corridor where two streams meet, each agent's field then
leads along the side its own stream already walks on, every agent going that way
strengthens that side's flux, and the streams sort themselves into lanes (Treuille et
al. show this instability forming lanes in counterflow). The field is no longer the
same in both directions, so it is solved on the directed graph. A flow in one direction
only (a queue, a bottleneck, everyone to one exit) costs nothing extra, and neither does
a crossing at right angles: J · n̂ = 0.
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
        step = np.stack(np.unravel_index(self.cell_index[self.dst], shape), axis=1) - \
            np.stack(np.unravel_index(self.cell_index[self.src], shape), axis=1)
        self.unit = step / np.linalg.norm(step, axis=1)[:, None]  # (E, 2) direction src -> dst
        # the CSR layout of both graphs, once: entries by row, then column (the canonical
        # form scipy's COO -> CSR conversion gives), so a re-solve only fills in weights
        n = len(self.cell_index)
        self._layout = {}
        for directed, rows, cols in ((False, self.src, self.dst),
                                     (True, np.concatenate([self.dst, self.src]), np.concatenate([self.src, self.dst]))):
            order = np.lexsort((cols, rows))
            indptr = np.zeros(n + 1, dtype=np.int64)
            np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
            self._layout[directed] = (order, cols[order], indptr)

    def _matrix(self, weights: np.ndarray, directed: bool) -> csr_matrix:
        order, indices, indptr = self._layout[directed]
        n = len(self.cell_index)
        return csr_matrix((weights[order], indices, indptr), shape=(n, n))

    def distances(self, goal_cells: list, shape: tuple, cost: np.ndarray | None = None,
                  against: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """(F, nx, ny) least cost from every cell to each field's goal cells (inf where none
        leads); an edge costs its length times the mean ``cost`` of its two cells (per free
        cell, default 1). With ``against`` = (extra cost per metre walking each edge src
        -> dst, and dst -> src), the graph is directed: the cost is that of walking from a
        cell towards the goal."""
        return self.distances_on(self.weighted(cost, against), goal_cells, shape)

    def weighted(self, cost: np.ndarray | None = None,
                 against: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[csr_matrix, bool]:
        """The graph with its edges weighted as :meth:`distances` says, and whether it is
        directed: built once for several :meth:`distances_on`."""
        w = self.length if cost is None else self.length * 0.5 * (cost[self.src] + cost[self.dst])
        if against is None:
            return self._matrix(w, False), False
        # Dijkstra runs outward from the goal cells, so the edge an agent walks a -> b is b -> a
        return self._matrix(np.concatenate([w + self.length * against[0], w + self.length * against[1]]), True), True

    def distances_on(self, weighted: tuple[csr_matrix, bool], goal_cells: list, shape: tuple) -> np.ndarray:
        """(F, nx, ny) least cost from every cell to each field's goal cells on a graph
        :meth:`weighted` built (inf where none leads)."""
        graph, directed = weighted
        out = np.full((len(goal_cells),) + tuple(shape), np.inf)
        for k, goals in enumerate(goal_cells):
            goals = np.asarray(goals, dtype=np.int64).reshape(-1, 2)
            d = dijkstra(graph, directed=directed, indices=self.node[goals[:, 0], goals[:, 1]], min_only=True)
            out[k].ravel()[self.cell_index] = d
        return out


class CongestionRouter:
    """Re-solves a :class:`DistanceFields` with density-weighted cell costs, and costs for
    walking against the crowd's flux."""

    def __init__(self, fields: DistanceFields, congestion: float, counterflow: float = 0.0):
        self.fields = fields
        self.congestion = float(congestion)
        self.counterflow = float(counterflow)
        free = ~fields.blocked
        self.enabled = (self.congestion > 0 or self.counterflow > 0) and free.size <= MAX_CELLS
        if self.enabled:
            self.graph = GridGraph(free, fields.cell)

    def bins(self, positions: np.ndarray) -> np.ndarray:
        """(N,) each agent's cell of the field grid, flattened (−1 off the grid)."""
        f = self.fields
        shape = f.blocked.shape
        idx = np.floor((positions - f.origin) / f.cell).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < np.array(shape)), axis=1)
        return np.where(inside, idx[:, 0] * shape[1] + idx[:, 1], -1)

    def density(self, positions: np.ndarray, weights: np.ndarray | None = None,
                bins: np.ndarray | None = None) -> np.ndarray:
        """(nx, ny) agents per m² on the field grid, smoothed over ~SMOOTH_M metres; with
        ``weights``, the smoothed sum of each agent's weight per m² instead (its velocity
        along an axis gives the flux). ``bins``: the agents' cells, if known (:meth:`bins`)."""
        f = self.fields
        shape = f.blocked.shape
        b = self.bins(positions) if bins is None else bins
        inside = b >= 0
        counts = np.bincount(b[inside], None if weights is None else weights[inside],
                             minlength=shape[0] * shape[1]).astype(float).reshape(shape)
        return gaussian_filter(counts / f.cell ** 2, SMOOTH_M / f.cell, mode="constant")

    def against(self, positions: np.ndarray, velocities: np.ndarray,
                bins: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Extra cost per metre of walking each edge of the graph src -> dst and dst -> src:
        ``counterflow`` × the flux coming the other way, max(0, ∓J · n̂), J taken at the
        edge's middle (the mean of its two cells)."""
        g = self.graph
        b = self.bins(positions) if bins is None else bins
        jx = self.density(positions, velocities[:, 0], b).ravel()[g.cell_index]
        jy = self.density(positions, velocities[:, 1], b).ravel()[g.cell_index]
        along = 0.5 * ((jx[g.src] + jx[g.dst]) * g.unit[:, 0] + (jy[g.src] + jy[g.dst]) * g.unit[:, 1])
        return self.counterflow * np.maximum(-along, 0.0), self.counterflow * np.maximum(along, 0.0)

    def resolve(self, positions: np.ndarray, exact: np.ndarray, velocities: np.ndarray | None = None,
                fields: np.ndarray | None = None) -> np.ndarray:
        """New (F, nx, ny) fields: the weighted distance to each field's goal cells, from
        where the agents are (and, with ``counterflow``, how they walk: ``velocities``).
        With ``fields`` (indices), only those are re-solved; the others keep ``exact``."""
        if not self.enabled or len(positions) == 0:
            return exact
        if fields is None or len(fields) == len(self.fields.goal_cells):
            return self.solve(positions, np.arange(len(self.fields.goal_cells)), velocities)
        out = exact.copy()
        out[fields] = self.solve(positions, fields, velocities)
        return out

    def weights(self, positions: np.ndarray, velocities: np.ndarray | None = None):
        """The grid's graph weighted for a re-solve, from where the agents are
        (``positions``, at least one) and, with ``counterflow``, how they walk
        (:meth:`GridGraph.weighted`), for :meth:`solve`."""
        bins = self.bins(positions)  # one binning for the density and both flux components
        cost = 1.0 + self.congestion * self.density(positions, bins=bins).ravel()[self.graph.cell_index]
        against = None
        if self.counterflow > 0 and velocities is not None:
            against = self.against(positions, velocities, bins)
        return self.graph.weighted(cost, against)

    def solve(self, positions: np.ndarray, fields: np.ndarray, velocities: np.ndarray | None = None,
              weights=None) -> np.ndarray:
        """(len(fields), nx, ny): the weighted distances of the fields ``fields`` (indices)
        from where the agents are and how they walk, or by ``weights`` taken earlier
        (:meth:`weights`)."""
        weighted = self.weights(positions, velocities) if weights is None else weights
        goal_cells = self.fields.goal_cells
        return self.graph.distances_on(weighted, [goal_cells[k] for k in fields], self.fields.blocked.shape)
