"""Congestion-aware guidance: the distance field re-solved with a cost that grows with
the local density, so a crowd spreads over the width of a corridor instead of every
agent queueing along the shortest line (the inner wall of a corner).

The idea is Treuille, Cooper & Popović's continuum crowds (2006): walking through a cell
costs ``1 + congestion × ρ`` per metre, ρ the density there (agents/m², smoothed over
about a metre). Every ``replan_s`` seconds the field is re-solved on the same
8-connected grid as the exact field (corner cutting off) by Dijkstra's algorithm, from all
goal cells at once; agents then aim along it exactly as before. The search stops once it
has settled every cell the field's agents can reach or look at before the next re-solve
(``near``): cells farther from the goal than all of those are left unsolved (inf), and the
cells solved hold the same distances as a search of the whole grid. With steps
shorter than a quarter second (a game's frames), the costs are taken
from the crowd at the period's first step and the fields' Dijkstras cut into slices
(:class:`FieldSearch`) spread over the steps of its first quarter second (over more,
up to the period, where the fields hold more than ``REPLAN_CELLS_PER_STEP`` cells a
step), the new fields taken together (the simulator's ``_replan``): the stand's 2000
walkers at 60 frames a second step in 9.5 ms in the frame that starts a re-solve,
against 14.7 ms with the search whole in it (``benchmarks/bench_rvo_live.py``).
With ``congestion = 0`` and ``counterflow = 0`` the field is the exact distance,
unchanged.

Walking against the crowd's flow (``counterflow > 0``, default 20) costs more on top:
continuum crowds take the speed a crowd allows in a direction from the flow there, so
that a cell where everyone walks towards you is slow to cross in your direction and fast
in theirs. Here a move in direction n̂ costs, per metre,

    1 + congestion · ρ + counterflow · max(0, −J(x + d · r̂) · n̂)

with J the crowd's flux (Σ of the agents' velocities per m², smoothed as ρ is; persons
per metre per second). In a corridor where two streams meet, each agent's field then
leads along the side its own stream already walks on, every agent going that way
strengthens that side's flux, and the streams sort themselves into lanes (Treuille et
al. show this instability forming lanes in counterflow).

Keeping right: J is read ``KEEP_RIGHT_M`` = d to the right (r̂) of the move, J(x + d · r̂)
(rounded to the field's cells: at the move on cells over 2d, the fields of bodies that
wide). A walker then finds an oncoming stream's flux where the stream would be if it
kept to its own right, and is led to its own right of it: the pedestrians' keep-right
convention (docs/rvo.md, "Keep right"), which every stream follows, so two streams
settle on opposite sides before their fronts meet. Read at the move, two streams that
reach a passage at once, each spread over its width, found no side dearer than the
other: their fronts met across the whole width and stood (the built-in
``rvo_blocked_street``: 4 of 60 home at seed 0; over seeds 0-59, 6 more took over a
minute on average); read to the right, all 60 seeds empty. Read to the right only where
the flux there comes head-on (within 45° of straight against the move), the crowds
converging on the 0.7 m door of ``crowdmotion verify --empirical`` stood less (seeds 0-4
and 10-74: no run under 1 person/s, against 7), but the 0.8 m bottleneck clogged more
(seeds 0-29: 2 runs under 1 person/s, against none; seeds 0-2 then fail the case):
within what the seeds alone move, and not kept. ``keep_right_deg = 0`` reads J at the
move. The field is no longer the same in both directions, so it is solved on the
directed graph. A flow in one direction only (a queue, a bottleneck, everyone to one
exit) costs nothing extra, and neither does a crossing at right angles: J · n̂ = 0.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from numba import njit, prange
from scipy.ndimage import gaussian_filter, maximum_filter
from scipy.sparse import csr_matrix

from crowdmotion._threads import threaded
from crowdmotion.routing import DistanceFields

SMOOTH_M = 0.75          # density is smoothed with a Gaussian of this many metres
KEEP_RIGHT_M = 0.3       # the oncoming flux is read this far to the right of a move (rounded to cells)
MAX_CELLS = 1_000_000    # larger fields keep the exact distances (re-solving would cost seconds)


class GridGraph:
    """The 8-connected graph of a grid's free cells (diagonals only where both cells beside
    them are free: no corner cutting), edges in metres, for scipy's Dijkstra."""

    def __init__(self, free: np.ndarray, cell: float):
        shape = free.shape
        self.cell = float(cell)
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
        # the CSR layout of the directed graph (each edge both ways), once: entries by row,
        # then column (the canonical form scipy's COO -> CSR conversion gives), so a
        # re-solve only fills in weights
        n = len(self.cell_index)
        rows, cols = np.concatenate([self.dst, self.src]), np.concatenate([self.src, self.dst])
        order = np.lexsort((cols, rows))
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
        self._layout = (order, cols[order].astype(np.int64), indptr)

    def beside(self, metres: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The cells ``metres`` to the right of each edge's two cells (flattened grid
        indices, clamped to the grid): (src, dst) walking src -> dst, then (src, dst)
        walking dst -> src, whose right is the other side. Rounded to whole cells: on
        cells over twice ``metres`` (the fields of bodies that wide), the edge's own."""
        shape = np.array(self.node.shape)
        src = np.stack(np.unravel_index(self.cell_index[self.src], tuple(shape)), axis=1)
        dst = np.stack(np.unravel_index(self.cell_index[self.dst], tuple(shape)), axis=1)
        right = np.stack([self.unit[:, 1], -self.unit[:, 0]], axis=1)
        off = np.rint(right * metres / self.cell).astype(np.int64)

        def flat(ij: np.ndarray) -> np.ndarray:
            ij = np.clip(ij, 0, shape - 1)
            return ij[:, 0] * shape[1] + ij[:, 1]

        return flat(src + off), flat(dst + off), flat(src - off), flat(dst - off)

    def csr(self, weighted: np.ndarray) -> csr_matrix:
        """The graph :meth:`weighted` gave as a scipy sparse matrix (row: from, column: to)."""
        _, indices, indptr = self._layout
        n = len(self.cell_index)
        return csr_matrix((weighted, indices, indptr), shape=(n, n))

    def distances(self, goal_cells: list, shape: tuple, cost: np.ndarray | None = None,
                  against: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """(F, nx, ny) least cost from every cell to each field's goal cells (inf where none
        leads); an edge costs its length times the mean ``cost`` of its two cells (per free
        cell, default 1). With ``against`` = (extra cost per metre walking each edge src
        -> dst, and dst -> src), the graph is directed: the cost is that of walking from a
        cell towards the goal."""
        return self.distances_on(self.weighted(cost, against), goal_cells, shape)

    def weighted(self, cost: np.ndarray | None = None,
                 against: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """The weights of the directed graph's edges in its CSR layout (each edge both ways;
        without ``against`` the same both ways), as :meth:`distances` says: built once for
        several :meth:`distances_on`."""
        order = self._layout[0]
        out = np.empty(len(order))
        no = np.zeros(0)
        _edge_weights(self.length, self.src, self.dst, no if cost is None else cost,
                      no if against is None else against[0], no if against is None else against[1], order, out)
        return out

    def distances_on(self, weighted: np.ndarray, goal_cells: list, shape: tuple,
                     near: list | None = None) -> np.ndarray:
        """(F, nx, ny) least cost from every cell to each field's goal cells on a graph
        :meth:`weighted` built (inf where none leads). ``near``, one (nx, ny) mask per field
        (or None), stops a field's search once every masked cell is solved: the cells left
        are inf; those solved hold the distances the whole search gives."""
        n_fields, n = len(goal_cells), len(self.cell_index)
        goals = [np.asarray(c, dtype=np.int64).reshape(-1, 2) for c in goal_cells]
        sources = [self.node[g[:, 0], g[:, 1]] for g in goals]
        starts = np.zeros(n_fields + 1, dtype=np.int64)
        np.cumsum([len(x) for x in sources], out=starts[1:])
        needed = np.ones((n_fields, n), dtype=bool)
        for k in range(n_fields):
            if near is not None and near[k] is not None:
                needed[k] = near[k].ravel()[self.cell_index]
        dist = np.empty((n_fields, n))
        _, indices, indptr = self._layout
        _dijkstras(starts, np.concatenate(sources) if sources else np.zeros(0, dtype=np.int64), indptr, indices,
                   weighted, needed, dist)
        out = np.full((n_fields,) + tuple(shape), np.inf)
        out.reshape(n_fields, -1)[:, self.cell_index] = dist
        return out


@njit(cache=True)
def _edge_weights(length, src, dst, cost, against_fwd, against_back, order, out):
    """:meth:`GridGraph.weighted` into ``out``: edge e (of E) walked src -> dst costs
    length · (mean ``cost`` of its cells, 1 if none given) + length · ``against_fwd[e]``,
    walked dst -> src the same with ``against_back`` (none given: 0). The directed graph's
    entries are edges 0 … 2E-1 (e + E: edge e walked back), in the CSR ``order``;
    Dijkstra runs outward from the goal cells, so the entry of an agent walking a -> b
    is the edge b -> a."""
    n_edges = length.shape[0]
    for q in range(order.shape[0]):
        e = order[q]
        back = e >= n_edges
        if back:
            e -= n_edges
        w = length[e]
        if cost.shape[0]:
            w *= 0.5 * (cost[src[e]] + cost[dst[e]])
        if against_fwd.shape[0]:
            w += length[e] * (against_back[e] if back else against_fwd[e])
        out[q] = w


@njit(cache=True)
def _against(jx, jy, fwd_a, fwd_b, back_a, back_b, unit, counterflow, ahead, back):
    """:meth:`CongestionRouter.against` per edge e: ``counterflow`` × max(0, −J · n̂)
    walking src -> dst (J the mean of cells ``fwd_a[e]`` and ``fwd_b[e]`` of the flux
    ``jx``, ``jy``; n̂ = ``unit[e]``), and × max(0, J · n̂) walking back (cells
    ``back_a``, ``back_b``), into ``ahead`` and ``back``."""
    for e in range(unit.shape[0]):
        a, b = fwd_a[e], fwd_b[e]
        along = 0.5 * ((jx[a] + jx[b]) * unit[e, 0] + (jy[a] + jy[b]) * unit[e, 1])
        ahead[e] = counterflow * max(-along, 0.0)
        a, b = back_a[e], back_b[e]
        along = 0.5 * ((jx[a] + jx[b]) * unit[e, 0] + (jy[a] + jy[b]) * unit[e, 1])
        back[e] = counterflow * max(along, 0.0)


@threaded(min_items=3)
def _dijkstras(starts, sources, indptr, indices, weights, needed, dist):
    """:func:`_dijkstra` for several fields at once, one a thread: field k from
    ``sources[starts[k]:starts[k + 1]]``, its needed nodes ``needed[k]``, into ``dist[k]``."""
    for k in prange(starts.shape[0] - 1):
        _dijkstra(indptr, indices, weights, sources[starts[k]:starts[k + 1]], needed[k], dist[k])


@njit(cache=True)
def _sift_up(key, node, slot, k, d, v):
    """Heap entry k gets distance d of node v, moved up to its place."""
    while k > 0:
        up = (k - 1) >> 1
        if key[up] <= d:
            break
        key[k] = key[up]
        node[k] = node[up]
        slot[node[k]] = k
        k = up
    key[k] = d
    node[k] = v
    slot[v] = k


@njit(cache=True)
def _sift_down(key, node, slot, size, d, v):
    """The heap's top entry (of ``size``) gets distance d of node v, moved down to its place."""
    k = 0
    while True:
        c = 2 * k + 1
        if c >= size:
            break
        if c + 1 < size and key[c + 1] < key[c]:
            c += 1
        if key[c] >= d:
            break
        key[k] = key[c]
        node[k] = node[c]
        slot[node[k]] = k
        k = c
    key[k] = d
    node[k] = v
    slot[v] = k


@njit(cache=True)
def _search_start(sources, needed, dist, slot, key, node, state):
    """Set up a Dijkstra from any of ``sources`` (see :func:`_search_run`): every distance
    inf but the sources' 0, the heap (``key``, ``node``, with each node's entry in
    ``slot``: -1 never reached, -2 settled) holding the sources; ``state`` = (heap size,
    needed nodes not yet settled)."""
    n = dist.shape[0]
    for v in range(n):
        dist[v] = np.inf
        slot[v] = -1
    size = 0
    for s in sources:
        if slot[s] == -1:
            dist[s] = 0.0
            _sift_up(key, node, slot, size, 0.0, s)
            size += 1
    left = 0
    for v in range(n):
        left += needed[v]
    state[0] = size
    state[1] = left


@njit(cache=True)
def _search_run(indptr, indices, weights, needed, dist, slot, key, node, state, budget):
    """Settle up to ``budget`` more nodes of the Dijkstra :func:`_search_start` set up on a
    CSR graph (a binary heap with one entry per node, its distance lowered in place).
    Returns how many it settled. The search is over once every node ``needed`` that the
    sources reach is settled (``state``: the heap is empty or none is left); then the
    unsettled nodes' distances are inf. A
    settled node's distance is the least sum over paths, the same whatever order ties are
    settled in (adding a non-negative weight never lowers a sum), as scipy's gives, and
    the same however the search is cut into runs."""
    size = state[0]
    left = state[1]
    pops = 0
    while size > 0 and left > 0 and pops < budget:
        u = node[0]
        du = key[0]
        slot[u] = -2
        left -= needed[u]
        size -= 1
        pops += 1
        if size > 0:  # the last entry moved to the top and sifted down
            _sift_down(key, node, slot, size, key[size], node[size])
        for q in range(indptr[u], indptr[u + 1]):
            v = indices[q]
            at = slot[v]
            if at == -2:
                continue
            d = du + weights[q]
            if d < dist[v]:
                dist[v] = d
                if at == -1:
                    _sift_up(key, node, slot, size, d, v)
                    size += 1
                else:
                    _sift_up(key, node, slot, at, d, v)
    state[0] = size
    state[1] = left
    if size == 0 or left == 0:
        for v in range(dist.shape[0]):
            if slot[v] != -2:
                dist[v] = np.inf
    return pops


@njit(cache=True)
def _dijkstra(indptr, indices, weights, sources, needed, dist):
    """Least cost from any of ``sources`` to every node of a CSR graph into ``dist``,
    stopping once every node ``needed`` that the sources reach is settled; the unsettled
    nodes: inf (:func:`_search_start`, then :func:`_search_run` to its end)."""
    n = indptr.shape[0] - 1
    slot = np.empty(n, dtype=np.int64)
    key = np.empty(n)
    node = np.empty(n, dtype=np.int64)
    state = np.zeros(2, dtype=np.int64)
    _search_start(sources, needed, dist, slot, key, node, state)
    _search_run(indptr, indices, weights, needed, dist, slot, key, node, state, n + 1)


class FieldSearch:
    """One field's Dijkstra on a :class:`GridGraph`, run a slice at a time
    (:meth:`advance`): a re-solve spread over a game's frames, whose distances are those
    of the whole search at once (:meth:`GridGraph.distances_on`)."""

    def __init__(self, graph: GridGraph, weighted: np.ndarray, goal_cells, shape: tuple,
                 near: np.ndarray | None = None):
        n = len(graph.cell_index)
        goals = np.asarray(goal_cells, dtype=np.int64).reshape(-1, 2)
        self._graph, self._weighted, self.shape = graph, weighted, tuple(shape)
        self._needed = np.ones(n, dtype=bool) if near is None else near.ravel()[graph.cell_index]
        self._dist = np.empty(n)
        self._slot = np.empty(n, dtype=np.int64)
        self._key = np.empty(n)
        self._node = np.empty(n, dtype=np.int64)
        self._state = np.zeros(2, dtype=np.int64)
        self.settled = 0  # nodes settled so far
        self.done = False
        _search_start(graph.node[goals[:, 0], goals[:, 1]], self._needed, self._dist, self._slot, self._key,
                      self._node, self._state)

    def advance(self, pops: int) -> bool:
        """Settle up to ``pops`` more cells; whether the search is over."""
        if not self.done:
            _, indices, indptr = self._graph._layout
            self.settled += int(_search_run(indptr, indices, self._weighted, self._needed, self._dist, self._slot,
                                            self._key, self._node, self._state, max(int(pops), 0)))
            self.done = bool(self._state[0] == 0 or self._state[1] == 0)
        return self.done

    def distances(self) -> np.ndarray:
        """(nx, ny) the field (inf where no path leads or the search stopped short), once
        :meth:`advance` has said it is over."""
        if not self.done:
            raise RuntimeError("the search is not over: advance it to its end first")
        out = np.full(self.shape, np.inf)
        out.ravel()[self._graph.cell_index] = self._dist
        return out


class CongestionRouter:
    """Re-solves a :class:`DistanceFields` with density-weighted cell costs, and costs for
    walking against the crowd's flux."""

    def __init__(self, fields: DistanceFields, congestion: float, counterflow: float = 0.0,
                 keep_right: bool = True):
        """``keep_right``: read the oncoming flux ``KEEP_RIGHT_M`` to the right of each move
        (else at the move; see the module docstring)."""
        self.fields = fields
        self.congestion = float(congestion)
        self.counterflow = float(counterflow)
        self.keep_right = bool(keep_right)
        self.enabled = (self.congestion > 0 or self.counterflow > 0) and fields.blocked.size <= MAX_CELLS

    @cached_property
    def graph(self) -> GridGraph:
        """The free cells' graph, built at the first re-solve (an obstacle moved at every
        frame of a game rebuilds the router each frame; it re-solves every ``replan_s``)."""
        return GridGraph(~self.fields.blocked, self.fields.cell)

    @cached_property
    def _read_at(self):
        """Where the oncoming flux is read for each edge (:meth:`GridGraph.beside`)."""
        return self.graph.beside(KEEP_RIGHT_M if self.keep_right else 0.0)

    def bins(self, positions: np.ndarray) -> np.ndarray:
        """(N,) each agent's cell of the field grid, flattened (−1 off the grid)."""
        f = self.fields
        shape = f.blocked.shape
        idx = f.cells(positions)
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
        ``counterflow`` × the flux coming the other way, max(0, ∓J · n̂), J the mean of the
        edge's two cells, read ``KEEP_RIGHT_M`` to the right of the way walked (with
        ``keep_right``; else at the edge's own cells)."""
        g = self.graph
        b = self.bins(positions) if bins is None else bins
        jx = self.density(positions, velocities[:, 0], b).ravel()
        jy = self.density(positions, velocities[:, 1], b).ravel()
        ahead, back = np.empty(len(g.unit)), np.empty(len(g.unit))  # walking src -> dst, and dst -> src
        _against(jx, jy, *self._read_at, g.unit, self.counterflow, ahead, back)
        return ahead, back

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
              weights=None, near: list | None = None) -> np.ndarray:
        """(len(fields), nx, ny): the weighted distances of the fields ``fields`` (indices)
        from where the agents are and how they walk, or by ``weights`` taken earlier
        (:meth:`weights`); ``near``: one mask of the cells needed (:meth:`near`) per field,
        or None for all (see :meth:`GridGraph.distances_on`)."""
        weighted = self.weights(positions, velocities) if weights is None else weights
        goal_cells = self.fields.goal_cells
        return self.graph.distances_on(weighted, [goal_cells[k] for k in fields], self.fields.blocked.shape, near)

    def searches(self, fields: np.ndarray, weights, near: list | None = None) -> list[FieldSearch]:
        """:meth:`solve`'s searches for the fields ``fields`` (indices) by ``weights``
        (:meth:`weights`), not yet run: each to be run a slice at a time
        (:meth:`FieldSearch.advance`)."""
        goal_cells = self.fields.goal_cells
        shape = self.fields.blocked.shape
        return [FieldSearch(self.graph, weights, goal_cells[k], shape, None if near is None else near[i])
                for i, k in enumerate(np.asarray(fields).tolist())]

    def near(self, points: np.ndarray, reach: float) -> np.ndarray:
        """(nx, ny) the cells within ``reach`` metres, along each axis, of any of ``points``."""
        f = self.fields
        cells = f.cell_of(points)
        mask = np.zeros(f.blocked.shape, dtype=np.uint8)
        mask[cells[:, 0], cells[:, 1]] = 1
        return maximum_filter(mask, size=2 * int(np.ceil(reach / f.cell)) + 1, mode="constant") > 0
