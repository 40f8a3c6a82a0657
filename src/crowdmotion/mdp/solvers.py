"""State values of the grid MDP (paper §1.3, §2.1): paper-faithful solvers and a fast exact one.

Every solver returns v with v = 0 on goal cells, v < 0 on cells that reach a goal, and
-inf on obstacles and unreachable cells. With gamma = 1 and reward -(move length),
|v(s)| is (approximately, for the paper's solvers) the shortest 8/26-connected path
length from s to the nearest goal.

``value_iteration``, ``heuristic_value_iteration``, ``improved_value_iteration`` and
``dijkstra`` are the paper's reference implementations in plain Python, written as
literally as the pseudo-code allows; they are slow on purpose and serve as baselines.
``fast_values`` is exact and numba-compiled; ``csgraph_values`` is exact by scipy's
Dijkstra on the same move graph. The library uses ``exact_values``: scipy on grids of up
to ``SCIPY_MAX_CELLS`` cells (tens of milliseconds, nothing to compile: a fresh install's
first run does not wait ten seconds for numba), the numba solver on larger ones.
"""

from __future__ import annotations

import heapq
import math
from typing import Iterable, Sequence

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra as csgraph_dijkstra

from crowdmotion.mdp.grid import validate_grid
from crowdmotion.mdp.moves import PAD, flat_move_tables, move_costs, move_offsets, successor_moves, swept_offsets

NEG_INF = -math.inf
METHODS = ("fast", "vi", "hvi", "ivi", "dijkstra", "dijkstra_unsorted")
SCIPY_MAX_CELLS = 250_000  # exact_values: scipy up to here (<= 0.1 s), the numba solver beyond


def normalise_goals(grid: np.ndarray, goal) -> list[tuple[int, ...]]:
    """Goal cells as a list of index tuples; ValueError if one is outside or on an obstacle."""
    arr = np.asarray(goal)
    if arr.dtype == object or arr.size == 0:
        raise ValueError(f"goal must be one cell index tuple or a list of them, got {goal!r}")
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != grid.ndim or not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"goal must be integer {grid.ndim}-index tuple(s) for a grid of shape {grid.shape}, got {goal!r}")
    goals = []
    for g in arr:
        t = tuple(int(x) for x in g)
        if any(x < 0 or x >= s for x, s in zip(t, grid.shape)):
            raise ValueError(f"goal {t} lies outside the grid of shape {grid.shape}")
        if grid[t]:
            raise ValueError(f"goal {t} is an obstacle cell")
        goals.append(t)
    return goals


# ---------------------------------------------------------------------------------
# fast exact solver
# ---------------------------------------------------------------------------------


def padded(grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(flat padded occupancy with a blocked border of width PAD, flat strides)."""
    pad = np.pad(grid, PAD, constant_values=1)
    strides = np.array([st // pad.itemsize for st in pad.strides], dtype=np.int64)
    return pad.ravel(), strides


def interior(flat: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The unpadded view of a padded flat array."""
    full = flat.reshape(tuple(s + 2 * PAD for s in shape))
    return full[tuple(slice(PAD, PAD + s) for s in shape)]


def fast_values(grid: np.ndarray, goals: Sequence[tuple[int, ...]], corner_cutting: bool = True,
                threads: int | None = None) -> np.ndarray:
    """Exact shortest-path values by Dial's bucket queue (numba), see ``_kernels``.

    Large buckets are split into parts run on numba's threads: up to ``threads`` parts
    (default: numba's thread count), at most ``MAX_PARTS`` in 3D and ``MAX_PARTS_2D`` in
    2D, and numba runs the solve on no more threads than that (a parallel region on idle
    threads costs their start and join).

    The result is a view into the padded work array (a contiguous copy would cost one
    more grid-sized allocation, a large share of the time on big 3D grids).
    """
    # imported here: the kernels (and the prefetch intrinsic they register with LLVM) cost
    # 0.2 s to import, which runs that only need exact_values' scipy path should not pay
    from crowdmotion.mdp._kernels import MAX_PARTS, MAX_PARTS_2D, bucket_distances, mark_near

    shape = grid.shape
    kind, strides = padded(grid)
    offsets, costs, _, swept, count = flat_move_tables(strides, corner_cutting)
    successors, successor_count = successor_moves(grid.ndim)
    dist = np.empty(kind.size)  # numpy's big allocations are quicker to touch than numba's
    parent = np.empty(kind.size, dtype=np.int8)
    if not corner_cutting:
        mark_near(kind, strides, dist.view(np.uint8))  # dist's bytes as scratch: filled later
    g = np.array([int(np.dot(np.add(t, PAD), strides)) for t in goals], dtype=np.int64)
    available = numba.get_num_threads()
    parts = min(available if threads is None else int(threads), MAX_PARTS if grid.ndim == 3 else MAX_PARTS_2D)
    numba.set_num_threads(max(1, min(parts, available)))
    try:
        bucket_distances(kind, dist, parent, g, offsets, costs, swept, count, successors, successor_count,
                         not corner_cutting, int(strides[0]), grid.ndim == 3, max(parts, 1))
    finally:
        numba.set_num_threads(available)
    return interior(dist, shape)  # a view: a contiguous copy would cost another big allocation


def move_graph(grid: np.ndarray, corner_cutting: bool = True) -> sp.csr_matrix:
    """The grid's free cells and the moves between them as a scipy graph (edge: the move's
    cost), for :func:`csgraph_values`: built once for several goals on one grid."""
    free = grid == 0
    idx = np.arange(grid.size).reshape(grid.shape)
    rows, cols, wts = [], [], []
    for off, cost, sweep in zip(move_offsets(grid.ndim), move_costs(grid.ndim), swept_offsets(grid.ndim)):
        src = tuple(slice(max(0, -o), s - max(0, o)) for o, s in zip(off, grid.shape))
        dst = tuple(slice(max(0, o), s - max(0, -o)) for o, s in zip(off, grid.shape))
        ok = free[src] & free[dst]
        if not corner_cutting:
            for sub in sweep:
                mid = tuple(slice(max(0, -o) + q, s - max(0, o) + q) for o, q, s in zip(off, sub, grid.shape))
                ok &= free[mid]
        rows.append(idx[src][ok])
        cols.append(idx[dst][ok])
        wts.append(np.full(int(ok.sum()), cost))
    return sp.csr_matrix((np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(grid.size, grid.size))


def csgraph_values(grid: np.ndarray, goals, corner_cutting: bool = True,
                   graph: sp.csr_matrix | None = None) -> np.ndarray:
    """Values by scipy.sparse.csgraph.dijkstra on the same move graph (graph build included,
    unless ``graph``, :func:`move_graph`'s of this grid, is given)."""
    graph = move_graph(grid, corner_cutting) if graph is None else graph
    flat = [int(np.ravel_multi_index(g, grid.shape)) for g in goals]
    d = csgraph_dijkstra(graph, directed=True, indices=flat, min_only=True)
    return -d.reshape(grid.shape)


def exact_values(grid: np.ndarray, goals: Sequence[tuple[int, ...]], corner_cutting: bool = True,
                 graph: sp.csr_matrix | None = None) -> np.ndarray:
    """Exact values by whichever solver gives a first result sooner: scipy's Dijkstra up
    to ``SCIPY_MAX_CELLS`` cells (on ``graph``, :func:`move_graph`'s, if given), the numba
    bucket solver (``fast_values``) beyond."""
    if grid.size <= SCIPY_MAX_CELLS:
        return csgraph_values(grid, goals, corner_cutting, graph)
    return fast_values(grid, goals, corner_cutting)


def exact_values_each(grid: np.ndarray, goal_sets: Sequence[Sequence[tuple[int, ...]]],
                      corner_cutting: bool = True, graph: sp.csr_matrix | None = None) -> list[np.ndarray]:
    """:func:`exact_values` for each set of goal cells on one grid, the move graph scipy's
    Dijkstra walks built once for them all (or ``graph``, :func:`move_graph`'s of this
    grid, built before)."""
    if graph is None and len(goal_sets) > 1 and grid.size <= SCIPY_MAX_CELLS:
        graph = move_graph(grid, corner_cutting)
    return [exact_values(grid, goals, corner_cutting, graph) for goals in goal_sets]


# ---------------------------------------------------------------------------------
# paper reference solvers (plain Python)
# ---------------------------------------------------------------------------------


def neighbour_table(grid: np.ndarray, corner_cutting: bool) -> list[list[tuple[int, float]]]:
    """get_neighbors(s) of the paper for every cell: free cells one move away and R's size.

    Plain Python, built once per solve. Obstacle cells get no neighbours (absorbing).
    """
    shape = grid.shape
    dim = grid.ndim
    occ = grid.ravel().tolist()
    strides = [int(np.prod(shape[i + 1 :])) for i in range(dim)]
    moves = [tuple(int(x) for x in o) for o in move_offsets(dim)]
    costs = [float(c) for c in move_costs(dim)]
    sweeps = swept_offsets(dim) if not corner_cutting else tuple(() for _ in moves)
    table: list[list[tuple[int, float]]] = []
    for flat in range(len(occ)):
        rem = flat
        coord = []
        for st in strides:
            coord.append(rem // st)
            rem -= coord[-1] * st
        nbrs: list[tuple[int, float]] = []
        if not occ[flat]:
            for mv, cost, sweep in zip(moves, costs, sweeps):
                c2 = [coord[k] + mv[k] for k in range(dim)]
                if any(c < 0 or c >= shape[k] for k, c in enumerate(c2)):
                    continue
                f2 = sum(c2[k] * strides[k] for k in range(dim))
                if occ[f2]:
                    continue
                if any(occ[sum((coord[k] + sub[k]) * strides[k] for k in range(dim))] for sub in sweep):
                    continue
                nbrs.append((f2, cost))
        table.append(nbrs)
    return table


def _sweeps(v: list[float], table, goal_set: set[int], theta: float, max_sweeps: int) -> int:
    """Algorithm 1's loop: in-place Bellman sweeps until the largest change < theta."""
    n = len(v)
    for sweep in range(1, max_sweeps + 1):
        delta = 0.0
        for s in range(n):
            if s in goal_set or not table[s]:  # goal and obstacles are absorbing
                continue
            old = v[s]
            best = NEG_INF
            for s2, cost in table[s]:
                cand = v[s2] - cost  # R(s, a, s') + v(s')
                if cand > best:
                    best = cand
            v[s] = best
            if old != best:  # -inf - -inf would be NaN: an unchanged -inf is no change
                delta = max(delta, abs(old - best))
        if delta < theta:
            return sweep
    raise RuntimeError(f"value iteration did not reach delta < theta={theta} within {max_sweeps} sweeps")


def _reachable(table, goals: Iterable[int]) -> set[int]:
    seen = set(goals)
    stack = list(seen)
    while stack:
        s = stack.pop()
        for s2, _ in table[s]:
            if s2 not in seen:
                seen.add(s2)
                stack.append(s2)
    return seen


def _flat_goals(grid, goals) -> list[int]:
    return [int(np.ravel_multi_index(g, grid.shape)) for g in goals]


def value_iteration(grid, goals, theta: float = 1.0, corner_cutting: bool = True,
                    init: np.ndarray | None = None, max_sweeps: int = 100_000):
    """Algorithm 1: v = -inf everywhere, 0 on goals, sweep until Delta < theta.

    ``init`` warm-starts from given values (used when obstacles move). Returns
    ``(values, sweeps)``.
    """
    table = neighbour_table(grid, corner_cutting)
    g = _flat_goals(grid, goals)
    if init is None:
        v = [NEG_INF] * grid.size
    else:
        v = [float(x) if np.isfinite(x) else NEG_INF for x in np.asarray(init, dtype=float).ravel()]
        for s in range(len(v)):
            if not table[s]:
                v[s] = NEG_INF
    for s in g:
        v[s] = 0.0
    sweeps = _sweeps(v, table, set(g), theta, max_sweeps)
    return np.array(v).reshape(grid.shape), sweeps


def heuristic_value_iteration(grid, goals, theta: float = 1.0, corner_cutting: bool = True,
                              max_sweeps: int = 100_000):
    """HVI: Algorithm 1 started from v(s) = -(Euclidean distance to the nearest goal).

    Cells that cannot reach any goal start at -inf: from a finite optimistic start, an
    enclosed pocket would lose ~1 per sweep for ever and never meet the theta rule.
    Returns ``(values, sweeps)``.
    """
    table = neighbour_table(grid, corner_cutting)
    g = _flat_goals(grid, goals)
    reach = _reachable(table, g)
    shape = grid.shape
    v = [NEG_INF] * grid.size
    for s in reach:
        coord = np.unravel_index(s, shape)
        v[s] = -min(math.dist(coord, goal) for goal in goals)
    sweeps = _sweeps(v, table, set(g), theta, max_sweeps)
    return np.array(v).reshape(grid.shape), sweeps


def greedy_estimate(grid, goals, corner_cutting: bool = True, table=None) -> np.ndarray:
    """Algorithm 2: values set once, on first discovery, in best-first order (never relaxed).

    As the paper's implementation note says, costs are kept positive in the queue and
    negated at the end.
    """
    table = neighbour_table(grid, corner_cutting) if table is None else table
    g = _flat_goals(grid, goals)
    cost = [math.inf] * grid.size
    pq: list[tuple[float, int]] = []
    block = set()
    for s in g:
        cost[s] = 0.0
        heapq.heappush(pq, (0.0, s))
        block.add(s)
    while pq:
        _, s = heapq.heappop(pq)
        for s2, c in table[s]:
            if s2 not in block:
                cost[s2] = cost[s] + c
                heapq.heappush(pq, (cost[s2], s2))
                block.add(s2)
    return -np.array(cost).reshape(grid.shape)


def improved_value_iteration(grid, goals, theta: float = 1.0, corner_cutting: bool = True,
                             max_sweeps: int = 100_000):
    """IVI, the paper's contribution: Algorithm 2's greedy estimate, then Algorithm 1.

    Returns ``(values, sweeps)``.
    """
    table = neighbour_table(grid, corner_cutting)
    g = _flat_goals(grid, goals)
    v = greedy_estimate(grid, goals, corner_cutting, table).ravel().tolist()
    sweeps = _sweeps(v, table, set(g), theta, max_sweeps)
    return np.array(v).reshape(grid.shape), sweeps


def dijkstra(grid, goals, corner_cutting: bool = True) -> np.ndarray:
    """Classic Dijkstra with heapq and lazy deletion, on the same graph (baseline)."""
    table = neighbour_table(grid, corner_cutting)
    g = _flat_goals(grid, goals)
    dist = [math.inf] * grid.size
    pq = []
    for s in g:
        dist[s] = 0.0
        pq.append((0.0, s))
    heapq.heapify(pq)
    while pq:
        d, s = heapq.heappop(pq)
        if d > dist[s]:
            continue
        for s2, c in table[s]:
            nd = d + c
            if nd < dist[s2]:
                dist[s2] = nd
                heapq.heappush(pq, (nd, s2))
    return -np.array(dist).reshape(grid.shape)


def dijkstra_unsorted(grid, goals, corner_cutting: bool = True) -> np.ndarray:
    """Dijkstra as the paper most likely timed it (Tables 1-2): the textbook form with no
    priority queue, every step scanning all unvisited cells for the nearest, O(n²).

    The paper does not say which Dijkstra it ran. Its times rule out a binary heap's
    O(n log n) (:func:`dijkstra`, which runs level with IVI): its Dijkstra / IVI ratio
    grows about as fast as the grid (4.6x to 25x while the 3D grids grow 6.25x), as an
    O(n²) scan against IVI's O(n) does. The scan is Python's ``min`` over the set of
    unvisited cells, the quickest way to write that form in plain Python.
    """
    table = neighbour_table(grid, corner_cutting)
    dist = [math.inf] * grid.size
    for s in _flat_goals(grid, goals):
        dist[s] = 0.0
    unvisited = set(np.flatnonzero(grid.ravel() == 0).tolist())
    while unvisited:
        s = min(unvisited, key=dist.__getitem__)
        d = dist[s]
        if d == math.inf:  # the rest cannot be reached
            break
        unvisited.remove(s)
        for s2, c in table[s]:
            if d + c < dist[s2]:
                dist[s2] = d + c
    return -np.array(dist).reshape(grid.shape)


# ---------------------------------------------------------------------------------
# entry point
# ---------------------------------------------------------------------------------


def solve(grid, goal, method: str = "fast", theta: float = 1.0, corner_cutting: bool = True) -> np.ndarray:
    """State values v(s) of the grid MDP.

    Parameters
    ----------
    grid : array of 0/1, 2 or 3 axes (1 = obstacle)
    goal : one cell index tuple, or a list of them (every goal cell starts at 0)
    method : "fast" (exact: ``exact_values``), or the paper's reference solvers "vi" (Algorithm 1),
        "hvi" (Algorithm 1 from -Euclidean distance), "ivi" (Algorithm 2 then 1),
        "dijkstra" (heapq), "dijkstra_unsorted" (no queue, O(n²): the paper's likely baseline)
    theta : the stopping threshold of Algorithm 1 (paper: 1.0); ignored by exact methods
    corner_cutting : True = the paper's rule (any move into a free cell); False = a
        diagonal move needs every cell it sweeps past free

    Returns
    -------
    float64 array of grid's shape: 0 on goals, negative where a goal is reachable,
    -inf on obstacles and unreachable cells.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if not (isinstance(theta, (int, float)) and np.isfinite(theta) and theta > 0):
        raise ValueError(f"theta must be a positive number, got {theta!r}")
    grid = validate_grid(grid)
    goals = normalise_goals(grid, goal)
    if method == "fast":
        return exact_values(grid, goals, corner_cutting)
    if method == "dijkstra":
        return dijkstra(grid, goals, corner_cutting)
    if method == "dijkstra_unsorted":
        return dijkstra_unsorted(grid, goals, corner_cutting)
    solver = {"vi": value_iteration, "hvi": heuristic_value_iteration, "ivi": improved_value_iteration}[method]
    return solver(grid, goals, theta=theta, corner_cutting=corner_cutting)[0]
