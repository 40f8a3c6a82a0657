"""Numba kernels of the MDP method: the exact bucketed solver and Algorithm 3's step loop.

Both work on flat indices into a grid padded with ``PAD`` blocked cells on every side,
so no neighbour lookup needs a bounds check.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from crowdmotion._prefetch import prefetch
from crowdmotion._threads import threaded
from crowdmotion.mdp.moves import PAD  # noqa: F401  (the kernels' grids carry this border)

# --------------------------------------------------------------------------------------
# Exact shortest-path values ("fast" solver)
# --------------------------------------------------------------------------------------
#
# Dial's algorithm with bucket width 1 = the smallest move cost. A cell whose tentative
# distance lies in [k, k+1) when bucket k is reached is final: any predecessor on a
# shorter path is at least 1 closer, so it sat in an earlier bucket and was already
# expanded. Moves cost at most sqrt(3) < 2, so pushes from bucket k land in k+1 or k+2:
# three rotating buckets suffice. No heap.
#
# Three things keep the inner loop short:
# - obstacle and border cells hold the distance -1, so "nd < dist[v]" also rejects
#   them and the free-cell test costs no extra load;
# - each cell remembers the move it was last improved by and relaxes only the moves
#   that can still improve something after it (``moves.successor_moves``). Among
#   equally short ways in, it keeps the one leaving the fewest (a straight move leaves
#   3 of 8 in 2D, 9 of 26 in 3D): on the benchmark grids 3.0 relaxations per cell in 2D,
#   9.2 in 3D, against 8 and 26. With corner cutting off this holds only where the
#   cell's whole 3^d box is free (``NEAR`` cells expand fully);
# - in 3D each bucket is counting-sorted by plane (the slowest axis), so cells are
#   visited in near-memory order. Large 3D buckets are then split between the threads
#   by plane: cells more than one plane apart touch disjoint cells, so the parts run at
#   once and the two planes at each seam between parts run after them. Cells of one
#   bucket do not depend on each other, so the distances do not depend on that order.
#   A 3D bucket of n cells gets min(threads, n / (PARALLEL_MIN / 2), MAX_PARTS) parts,
#   so every part has work enough to pay for its thread. 2D buckets are split in two the
#   same way by rows, around a sampled median row, without sorting.

BLOCKED = 1
"""``kind`` bit: obstacle or border cell."""
NEAR = 2
"""``kind`` bit: a free cell with an obstacle or border cell in its 3^d box."""
TIE = 1e-6
"""Offers this close to a cell's distance count as ties when choosing its parent move:
any value below the pruning margin (0.58, see ``moves.successor_moves``) is safe."""
PARALLEL_MIN = 4096
"""Smallest 3D bucket worth splitting between two threads (each further thread wants
another PARALLEL_MIN / 2 cells)."""
PARALLEL_MIN_2D = 512
"""Smallest 2D bucket worth splitting between two threads (by row, unsorted)."""
MAX_PARTS = 4
"""Most parts a 3D bucket is split into, whatever the thread count: measured on 16 cores
(docs/performance.md), 200^3 gains from 1 to 2 and 4 threads and loses beyond, where
each bucket's parallel region costs more to start and join than its share of work."""
MAX_PARTS_2D = 2
"""Most parts a 2D bucket is split into: a 2D front is too thin to share further (on
16 cores 1000^2 gained nothing from 2 threads and lost from 4)."""


@njit(cache=True, parallel=True)
def mark_near(kind, strides, scratch):
    """Set the NEAR bit on every free cell whose 3^d box holds a BLOCKED cell.

    ``kind`` is a padded flat array with flat ``strides``; ``scratch`` is a uint8 work
    array of twice its length (big arrays come from numpy, whose allocations are faster
    to touch). The box is dilated one axis at a time with flat offsets, the last axis
    straight into ``kind``: the border is at least one cell wide, so for every cell of
    the grid itself the offsets never wrap into another row or plane.
    """
    n = kind.shape[0]
    src = scratch[:n]
    dst = scratch[n : 2 * n]
    for x in prange(n):
        src[x] = kind[x] & BLOCKED
    for k in range(strides.shape[0] - 1, 0, -1):  # fastest axis first
        s = strides[k]
        dst[:s] = src[:s]
        dst[n - s :] = src[n - s :]
        for x in prange(s, n - s):
            dst[x] = src[x - s] | src[x] | src[x + s]
        src, dst = dst, src
    s = strides[0]
    for x in prange(s, n - s):
        if (src[x - s] | src[x] | src[x + s]) and not (kind[x] & BLOCKED):
            kind[x] |= NEAR


@njit(cache=True)
def _expand(order, start, stop, lo, hi, dist, parent, kind, tables, check_near, buckets, sizes):
    """Expand the cells ``order[start:stop]`` of the bucket [lo, hi): relax, record, push.

    ``tables`` = ``_successor_tables(...)``.
    """
    step, step_cost, step_move, count, offsets, swept, swept_count = tables
    full_row = count.shape[0] - 1
    # pushes land in bucket k + 1 or k + 2 (moves cost 1 to sqrt(3)): two local tails
    k = int(lo)
    near_b = (k + 1) % 3
    far_b = (k + 2) % 3
    n_near = sizes[near_b]
    n_far = sizes[far_b]
    edge = lo + 2.0
    for i in range(start, stop):
        u = order[i]
        du = dist[u]
        if du < lo or du >= hi:  # expanded in an earlier bucket, or improved since
            continue
        a = parent[u]
        full = a < 0 or (check_near and (kind[u] & NEAR) != 0)
        if full:
            a = full_row
        for q in range(count[a]):
            v = u + step[a, q]
            nd = du + step_cost[a, q]
            old = dist[v]
            if nd >= old:  # never an improvement for obstacle cells (dist -1)
                if nd < old + TIE:
                    m = step_move[a, q]
                    if count[m] < count[parent[v]]:
                        parent[v] = m  # an equally short way in that leaves fewer moves to try
                continue
            m = step_move[a, q]
            if full and not _sweep_free(kind, u, swept, swept_count, m):
                continue
            dist[v] = nd
            parent[v] = m
            if nd < edge:
                if old >= edge:  # else already waiting in bucket k + 1 (not yet expanded)
                    buckets[near_b, n_near] = v
                    n_near += 1
            elif old == np.inf:  # improvements within bucket k + 2 are already queued
                buckets[far_b, n_far] = v
                n_far += 1
    sizes[near_b] = n_near
    sizes[far_b] = n_far


@njit(cache=True)
def _sweep_free(cells, u, swept, swept_count, m):
    """No cell that move ``m`` from ``u`` sweeps past has the BLOCKED bit (corner rule)."""
    for j in range(swept_count[m]):
        if cells[u + swept[m, j]] & BLOCKED:
            return False
    return True


@njit(cache=True)
def _successor_tables(offsets, costs, swept, swept_count, successors, successor_count):
    """Per parent move: the flat steps, costs and move indices a cell relaxes.

    Row ``n_moves`` is "no usable parent": every move (goals, and NEAR cells when
    corner cutting is off). Folding offsets and costs in by position saves two
    dependent loads per relaxation (measured 1.4x on 200^3).
    """
    n_moves = offsets.shape[0]
    count = np.empty(n_moves + 1, dtype=np.int64)
    step_move = np.zeros((n_moves + 1, n_moves), dtype=np.int64)
    for a in range(n_moves):
        count[a] = successor_count[a]
        step_move[a, : count[a]] = successors[a, : count[a]]
    count[n_moves] = n_moves
    step_move[n_moves] = np.arange(n_moves)
    step = np.zeros((n_moves + 1, n_moves), dtype=np.int64)
    step_cost = np.zeros((n_moves + 1, n_moves))
    for a in range(n_moves + 1):
        for q in range(count[a]):
            step[a, q] = offsets[step_move[a, q]]
            step_cost[a, q] = costs[step_move[a, q]]
    return step, step_cost, step_move, count, offsets, swept, swept_count


@njit(cache=True)
def _reserve(buckets, sizes, extra):
    """``buckets`` (one set of three lists per part) with room for ``extra`` more entries
    in every list (grown if needed)."""
    need = 0
    for t in range(buckets.shape[0]):
        for b in range(3):
            need = max(need, sizes[t, b] + extra)
    if need <= buckets.shape[2]:
        return buckets
    new = np.empty((buckets.shape[0], 3, max(need, 2 * buckets.shape[2])), dtype=np.int64)
    for t in range(buckets.shape[0]):
        for b in range(3):
            new[t, b, : sizes[t, b]] = buckets[t, b, : sizes[t, b]]
    return new


@njit(cache=True, parallel=True)
def _expand_split(order, ranges, parts, lo, hi, dist, parent, kind, tables, check_near, buckets, sizes):
    """One thread per part expands ``order[ranges[t, 0]:ranges[t, 1]]``, pushing to the
    part's own lists ``t``."""
    for t in prange(parts):
        _expand(order, ranges[t, 0], ranges[t, 1], lo, hi, dist, parent, kind, tables, check_near, buckets[t],
                sizes[t])


@njit(cache=True)
def bucket_distances(kind, dist, parent, goals, offsets, costs, swept, swept_count, successors, successor_count,
                     check_near, plane, three_d, threads):
    """Exact 8/26-connected state values (minus the distance to the nearest goal) in ``dist``.

    Parameters
    ----------
    kind : uint8[:]      padded flat cell kinds: BLOCKED bit, NEAR bit (``mark_near``)
    dist : float64[:]    padded flat output: minus the distance, -inf on obstacle, border
                         and unreachable cells (distances while running, -1 on BLOCKED)
    parent : int8[:]     padded flat work array: the move each cell was last improved by
    goals : int64[:]     padded flat indices of the goal cells
    offsets, costs, swept, swept_count : the move tables of ``moves.flat_move_tables``
    successors, successor_count : ``moves.successor_moves``
    check_near : bool    corner cutting is off: NEAR cells expand fully, with sweep checks
    plane : int          flat stride of the slowest axis (a plane in 3D, a row in 2D)
    three_d : bool       3D: sort each bucket by plane; 2D: partition large ones by row.
                         Either way large buckets are split into parts, one per thread.
    threads : int        most parts a bucket is split into (numba's thread count)
    """
    n_cells = kind.shape[0]
    n_moves = offsets.shape[0]
    n_planes = n_cells // plane + 1
    parts_max = max(threads, 1)
    tables = _successor_tables(offsets, costs, swept, swept_count, successors, successor_count)
    buckets = np.empty((parts_max, 3, max(1024, goals.shape[0])), dtype=np.int64)
    sizes = np.zeros((parts_max, 3), dtype=np.int64)
    order = np.empty(1024, dtype=np.int64)
    seam = np.empty(1024, dtype=np.int64)
    hist = np.zeros((parts_max, n_planes), dtype=np.int64)
    ranges = np.zeros((parts_max, 2), dtype=np.int64)
    minimum = PARALLEL_MIN if three_d else PARALLEL_MIN_2D
    cap = parts_max if three_d else min(parts_max, MAX_PARTS_2D)  # fast_values caps 3D at MAX_PARTS
    _over_all_cells(kind, dist, parent, True, parts_max)
    for g in goals:
        dist[g] = 0.0
        buckets[0, 0, sizes[0, 0]] = g
        sizes[0, 0] += 1
    k = 0
    while sizes.sum() > 0:
        b = k % 3
        n = sizes[:, b].sum()
        if order.shape[0] < n:
            order = np.empty(2 * n, dtype=np.int64)
            seam = np.empty(2 * n, dtype=np.int64)
        parts = 1 if n < minimum else min(cap, n // (minimum // 2))
        if three_d:
            _order_by_plane(buckets, sizes, b, plane, hist, order, ranges, parts)
        elif parts > 1:
            _partition_by_row(buckets, sizes, b, plane, order, ranges, seam)
        else:
            m = 0
            for t in range(parts_max):
                order[m : m + sizes[t, b]] = buckets[t, b, : sizes[t, b]]
                m += sizes[t, b]
        sizes[:, b] = 0
        lo = float(k)
        hi = lo + 1.0
        if parts > 1:
            longest = 0
            for t in range(parts):
                longest = max(longest, ranges[t, 1] - ranges[t, 0])
            buckets = _reserve(buckets, sizes, longest * n_moves)
            _expand_split(order, ranges, parts, lo, hi, dist, parent, kind, tables, check_near, buckets, sizes)
            seams = 0
            for t in range(parts - 1):
                seams += ranges[t + 1, 0] - ranges[t, 1]
            buckets = _reserve(buckets, sizes, seams * n_moves)
            for t in range(parts - 1):  # the planes (rows) at each seam, after the parts
                _expand(order, ranges[t, 1], ranges[t + 1, 0], lo, hi, dist, parent, kind, tables, check_near,
                        buckets[0], sizes[0])
        else:
            buckets = _reserve(buckets, sizes, n * n_moves)
            _expand(order, 0, n, lo, hi, dist, parent, kind, tables, check_near, buckets[0], sizes[0])
        k += 1
    _over_all_cells(kind, dist, parent, False, parts_max)
    return dist


@njit(cache=True)
def _seam_cuts(first, n, parts, n_rows, cuts):
    """``parts - 1`` cut planes (rows), non-decreasing, at the quantiles of a bucket whose
    plane r starts at slot ``first[r]``. Part t holds the planes ``cuts[t-1] + 1 ..
    cuts[t] - 2`` and writes at most one plane beyond them, so parts touch disjoint cells;
    the seams (planes ``cuts[t] - 1``, ``cuts[t]``) run after the parts, on one thread."""
    j = 0
    for r in range(n_rows):
        while j < parts - 1 and first[r] >= (j + 1) * n // parts:
            cuts[j] = max(r - 1, 0)
            j += 1
    while j < parts - 1:
        cuts[j] = n_rows - 1
        j += 1


@njit(cache=True)
def _ranges_from_cuts(first, n, parts, cuts, n_rows, ranges):
    """Part t: the slots of rows ``cuts[t-1] + 1 .. cuts[t] - 2``; the seams (rows
    ``cuts[t] - 1`` and ``cuts[t]``) lie between parts t and t + 1 in the order."""
    for t in range(parts):
        start = 0 if t == 0 else first[cuts[t - 1] + 1]
        stop = n if t == parts - 1 else (first[cuts[t] - 1] if cuts[t] >= 1 else 0)
        ranges[t, 0] = start
        ranges[t, 1] = max(start, stop)


@njit(cache=True)
def _order_by_plane(buckets, sizes, b, plane, hist, order, ranges, parts):
    """Counting-sort bucket ``b`` (every part's list) by plane into ``order``; with
    ``parts`` > 1 set ``ranges`` to the parts the threads may expand at once (the planes
    between consecutive seams, see ``_seam_cuts``). Within a plane, entries keep their
    list order."""
    lists = sizes.shape[0]
    if parts > 1:
        _plane_histograms(buckets, sizes, b, plane, hist)
    else:
        for t in range(lists):
            _plane_histogram(buckets[t, b, : sizes[t, b]], plane, hist[t])
    n = sizes[:, b].sum()
    n_planes = hist.shape[1]
    first = np.empty(n_planes + 1, dtype=np.int64)
    running = 0
    for p in range(n_planes):  # hist becomes each list's first slot per plane
        first[p] = running
        for t in range(lists):
            c = hist[t, p]
            hist[t, p] = running
            running += c
    first[n_planes] = n
    if parts > 1:
        cuts = np.empty(parts - 1, dtype=np.int64)
        _seam_cuts(first, n, parts, n_planes, cuts)
        _ranges_from_cuts(first, n, parts, cuts, n_planes, ranges)
        _plane_scatters(buckets, sizes, b, plane, hist, order)
    else:
        for t in range(lists):
            _plane_scatter(buckets[t, b, : sizes[t, b]], plane, hist[t], order)


@njit(cache=True)
def _partition_by_row(buckets, sizes, b, row, order, ranges, seam):
    """2D: split bucket ``b`` into rows below ``cut - 1``, the seam rows ``cut - 1`` and
    ``cut``, and rows above ``cut``, without sorting (``ranges`` as ``_order_by_plane``
    with two parts).

    ``cut`` is the median row of 63 evenly spaced entries: near enough to balance the
    two threads, and a few microseconds where a counting sort over all rows costs more
    than the split saves.
    """
    lists = sizes.shape[0]
    n = sizes[:, b].sum()
    sample = np.empty(63, dtype=np.int64)
    for j in range(63):
        i = j * n // 63
        t = 0
        while i >= sizes[t, b]:
            i -= sizes[t, b]
            t += 1
        sample[j] = buckets[t, b, i] // row
    cut = np.sort(sample)[31]
    front = 0
    back = n
    n_seam = 0
    for t in range(lists):
        for i in range(sizes[t, b]):
            u = buckets[t, b, i]
            r = u // row
            if r < cut - 1:
                order[front] = u
                front += 1
            elif r > cut:
                back -= 1
                order[back] = u
            else:
                seam[n_seam] = u
                n_seam += 1
    order[front : front + n_seam] = seam[:n_seam]
    ranges[0, 0] = 0
    ranges[0, 1] = front
    ranges[1, 0] = back
    ranges[1, 1] = n


@njit(cache=True)
def _plane_histogram(cells, plane, counts):
    counts[:] = 0
    for u in cells:
        counts[u // plane] += 1


@njit(cache=True)
def _plane_scatter(cells, plane, slots, order):
    for u in cells:
        p = u // plane
        order[slots[p]] = u
        slots[p] += 1


@njit(cache=True, parallel=True)
def _plane_histograms(buckets, sizes, b, plane, hist):
    for t in prange(sizes.shape[0]):
        _plane_histogram(buckets[t, b, : sizes[t, b]], plane, hist[t])


@njit(cache=True, parallel=True)
def _plane_scatters(buckets, sizes, b, plane, hist, order):
    for t in prange(sizes.shape[0]):
        _plane_scatter(buckets[t, b, : sizes[t, b]], plane, hist[t], order)


@njit(cache=True)
def _start_distances(kind, dist, parent, lo, hi):
    """Cells [lo, hi): +inf on free cells, -1 on BLOCKED ones, no parent move yet."""
    for x in range(lo, hi):
        dist[x] = -1.0 if kind[x] & BLOCKED else np.inf
        parent[x] = -1


@njit(cache=True)
def _to_values(dist, lo, hi):
    """Cells [lo, hi): distances to state values in place, v = -distance, -inf if blocked."""
    for x in range(lo, hi):
        dist[x] = -np.inf if dist[x] < 0.0 else -dist[x]


@njit(cache=True)
def _over_all_cells(kind, dist, parent, start, threads):
    """``_start_distances`` (``start``) or ``_to_values`` over every cell: split between
    the threads for big grids, on this one for small ones (a parallel region costs more
    there)."""
    n = dist.shape[0]
    if n >= PARALLEL_MIN * 64 and threads > 1:
        _in_parts(kind, dist, parent, start, threads)
    elif start:
        _start_distances(kind, dist, parent, 0, n)
    else:
        _to_values(dist, 0, n)


@njit(cache=True, parallel=True)
def _in_parts(kind, dist, parent, start, parts):
    """``_start_distances`` (``start``) or ``_to_values`` over all cells, in ``parts``."""
    n = dist.shape[0]
    for t in prange(parts):
        lo = t * n // parts
        hi = (t + 1) * n // parts
        if start:
            _start_distances(kind, dist, parent, lo, hi)
        else:
            _to_values(dist, lo, hi)


# --------------------------------------------------------------------------------------
# Algorithm 3: trajectory generation
# --------------------------------------------------------------------------------------

TAKEN = 2
"""Algorithm 3 cell state bit: an agent stands here now (the paper's ``block``)."""
STARTED = 4
"""Algorithm 3 cell state bit: an agent stood here when the step began."""
AHEAD = 8
"""Algorithm 3 issues the memory loads of the agent this many places ahead in the order."""


@njit(cache=True)
def _priority_order(keys, order, rank, counts):
    """Fill ``order`` with the agents sorted by (key, agent id); ``+inf`` keys last.

    Counting sort into ``n`` equal-width buckets over the range of the finite keys
    (agents taken in id order, so ties stay by id), then an insertion sort, which only
    has to fix the order inside buckets: linear for any spread of keys but a few agents
    piling into one bucket. The same order as a stable argsort of ``keys``.
    ``rank`` and ``counts`` are work arrays of n and n + 2 entries.
    """
    n = order.shape[0]
    lo = np.inf
    hi = -np.inf
    for i in range(n):
        k = keys[i]
        if k < np.inf:
            lo = min(lo, k)
            hi = max(hi, k)
    scale = n / (hi - lo) if hi > lo else 0.0
    counts[:] = 0
    for i in range(n):
        k = keys[i]
        b = n if k == np.inf else min(int((k - lo) * scale), n - 1)
        rank[i] = b
        counts[b + 1] += 1
    for b in range(n + 1):
        counts[b + 1] += counts[b]
    for i in range(n):
        b = rank[i]
        order[counts[b]] = i
        counts[b] += 1
    for i in range(1, n):
        x = order[i]
        kx = keys[x]
        j = i - 1
        while j >= 0:
            y = order[j]
            ky = keys[y]
            if ky < kx or (ky == kx and y < x):
                break
            order[j + 1] = y
            j -= 1
        order[j + 1] = x


@njit(cache=True)
def _find(root, i):
    """Union-find root of ``i``, halving the path on the way."""
    while root[i] != i:
        root[i] = root[root[i]]
        i = root[i]
    return i


@njit(cache=True)
def _clusters(order, cur, active, occ, state, near_ahead, near_lines, parts, root, first, owner):
    """Share this step's turns between ``parts`` threads without changing any turn.

    A turn reads and writes only cells within two of the agent's start cell and the
    moves of agents that started there, so agents whose start cells are more than two
    apart (Chebyshev) never affect each other within a step. Fills ``root`` with each
    agent's cluster, the agents linked by that distance (union-find over each agent's
    Chebyshev-2 box: ``near_ahead`` is its half with positive offsets, ``near_lines``
    the lines to prefetch), named by its lowest agent id; ``first`` with each agent's
    place in the step's priority ``order``; and ``owner`` with the thread of each
    agent's cluster: the one whose share of the order its lowest-id agent's turn falls
    in (neighbouring values, so mostly neighbouring cells, and shares about equal). A
    thread that takes its clusters' turns in priority order gives the one-thread
    result, bit for bit.
    """
    n = order.shape[0]
    for i in range(n):
        root[i] = i
    for i in range(n):
        if i + AHEAD < n:
            c = cur[i + AHEAD]
            for q in range(near_lines.shape[0]):
                prefetch(state, c + near_lines[q])
                prefetch(occ, c + near_lines[q])
        if not active[i]:
            continue
        u = cur[i]
        for q in range(near_ahead.shape[0]):
            c = u + near_ahead[q]
            if state[c] & STARTED:
                j = occ[c]
                if active[j]:
                    ri = _find(root, i)
                    rj = _find(root, j)
                    if ri != rj:
                        root[max(ri, rj)] = min(ri, rj)
    for i in range(n):  # roots only ever point lower: one pass in id order flattens them
        root[i] = root[root[i]]
    for oi in range(n):
        first[order[oi]] = oi
    for i in range(n):
        owner[i] = first[root[i]] * parts // n


@threaded
def trajectory_steps(
    blocked,
    values,
    goal,
    field_of,
    offsets,
    move_vec,
    swept,
    swept_count,
    near_offsets,
    crossing,
    cur,
    coord,
    active,
    occ,
    uniforms,
    tau,
    forbid_crossing,
    despawn,
    gone_step,
    step_base,
    out,
    partition,
):
    """Run ``uniforms.shape[0]`` steps of Algorithm 3, in place.

    Parameters
    ----------
    blocked : uint8[:]       padded flat occupancy (obstacles and border)
    values : float64[:, :]   (F, cells) padded flat state values, one field per goal
    goal : uint8[:, :]       (F, cells) padded flat goal masks (absorbing cells); a goal
                             cell's value must be >= 0 (0, or its fill depth: an agent
                             there moves only to a free goal cell of larger value), or
                             -inf while it is blocked; every other cell's value is < 0
    field_of : int64[:]      which field each agent follows
    offsets : int64[:]       flat offset of each move; ``move_vec`` its (dim,) vector
    swept, swept_count       cells a diagonal sweeps past (corner-cutting rule)
    near_offsets : int64[:]  flat offsets of the Chebyshev-2 box (crossing check)
    crossing : int64[:, :]   ``crossing_masks`` for that box and the agents' radius
    cur : int64[:]           current cell of each agent (updated)
    coord : int64[:, :]      current cell coordinates of each agent (updated)
    active : uint8[:]        1 while the agent is in the scene (updated)
    occ : int32[:]           padded flat id of the active agent on each cell, -1 if none
                             (updated at the end of every step)
    uniforms : float64[:, :] (steps, N) U(0,1) draws for the roulette wheel
    tau : float              Boltzmann temperature (eq. 4)
    forbid_crossing : bool   reject moves passing closer than two radii (``crossing``)
    despawn : bool           remove agents on arrival
    gone_step : int64[:]     step at which each agent despawned, -1 while active (updated)
    step_base : int          global index of this call's first step
    out : int64[:, :, :]     (steps, N, D) cell of each agent after each step (unpadded)
    partition                None: every turn in priority order on this thread (the
                             serial compilation); or (parts, near_ahead, root, first,
                             owner): share each step's turns between ``parts`` threads
                             by ``_clusters`` (root, first, owner: work arrays of n)
    """
    n_steps, n = uniforms.shape
    dim = coord.shape[1]
    n_moves = offsets.shape[0]
    stay = n_moves
    n_near = near_offsets.shape[0]
    # One byte per cell keeps the hot tests in cache: obstacle, taken now (the paper's
    # ``block``), and someone stood here at the start of the step (``occ`` says who).
    state = np.empty(blocked.shape[0], dtype=np.uint8)
    for c in range(blocked.shape[0]):
        state[c] = BLOCKED if blocked[c] else 0
        if occ[c] >= 0:
            state[c] |= TAKEN | STARTED
    # (np.full, np.zeros, masks, np.concatenate and slice filling would each cost a
    # compile of its own: plain loops instead)
    move_of = np.empty(n, dtype=np.int64)  # this step's move of each agent (reset to stay)
    keys = np.empty(n, dtype=np.float64)
    order = np.empty(n, dtype=np.int64)
    rank = np.empty(n, dtype=np.int64)
    counts = np.empty(n + 2, dtype=np.int64)
    parts = 1 if partition is None else partition[0]
    lookahead = AHEAD * parts
    # cache lines a step reads around a cell: both ends of each row of the 3^d box (the
    # values) and of the Chebyshev-2 box (cell states, agent ids)
    n_lines = 0
    for m in range(n_moves):
        n_lines += move_vec[m, dim - 1] != 0.0
    value_lines = np.empty(n_lines, dtype=np.int64)
    n_lines = 0
    for m in range(n_moves):
        if move_vec[m, dim - 1] != 0.0:
            value_lines[n_lines] = offsets[m]
            n_lines += 1
    near_lines = np.empty((n_near + 4) // 5 + n_near // 5, dtype=np.int64)  # near_offsets[::5], [4::5]
    n_lines = 0
    for q in range(0, n_near, 5):
        near_lines[n_lines] = near_offsets[q]
        n_lines += 1
    for q in range(4, n_near, 5):
        near_lines[n_lines] = near_offsets[q]
        n_lines += 1
    for i in range(n):  # minus each agent's value; then kept up to date as agents move
        if i + AHEAD < n:
            prefetch(values[field_of[i + AHEAD]], cur[i + AHEAD])
        keys[i] = -values[field_of[i], cur[i]]
    for step in range(n_steps):
        for i in range(n):
            move_of[i] = stay
        _priority_order(keys, order, rank, counts)  # largest value first, ties by id
        if partition is not None:  # (numba prunes the branches the argument's type rules out)
            _, near_ahead, root, first, owner = partition
            _clusters(order, cur, active, occ, state, near_ahead, near_lines, parts, root, first, owner)
        for t in prange(parts):
            cand = np.empty(n_moves + 1, dtype=np.int64)  # candidate move (stay = n_moves)
            cand_val = np.empty(n_moves + 1, dtype=np.float64)
            weight = np.empty(n_moves + 1, dtype=np.float64)
            for oi in range(n):
                if oi + lookahead < n:  # about AHEAD of this thread's own turns ahead
                    ahead = order[oi + lookahead]
                    mine = True
                    if partition is not None:
                        mine = owner[ahead] == t
                    if mine:
                        c = cur[ahead]
                        row = values[field_of[ahead]]
                        for q in range(value_lines.shape[0]):
                            prefetch(row, c + value_lines[q])
                        if forbid_crossing:
                            for q in range(near_lines.shape[0]):
                                prefetch(state, c + near_lines[q])
                                prefetch(occ, c + near_lines[q])
                i = order[oi]
                if partition is not None:
                    if owner[i] != t:
                        continue
                if not active[i]:
                    continue
                u = cur[i]
                fi = field_of[i]
                vu = values[fi, u]
                # goal cells hold values >= 0 (their fill depth), or -inf while an obstacle covers
                # them; every other cell is < 0: read the mask only then
                in_goal = (vu >= 0.0 or vu == -np.inf) and goal[fi, u] != 0
                if in_goal and (despawn or vu == -np.inf):
                    if despawn:
                        active[i] = 0
                        state[u] &= ~TAKEN
                        gone_step[i] = step_base + step
                    continue
                state[u] &= ~TAKEN
                # moves that would pass too close to an agent whose start cell is within two
                # cells: the only ones a one-cell move can come within two radii (< 0.71) of
                forbidden = np.int64(0)
                if forbid_crossing:
                    for q in range(n_near):
                        c = u + near_offsets[q]
                        if state[c] & STARTED:
                            j = occ[c]
                            if j != i and active[j]:
                                forbidden |= crossing[q, move_of[j]]  # stay if j has not moved yet
                n0 = 0  # neighbors0 fill cand from the front, neighbors1 from the back
                n1 = 0
                for m in range(n_moves):
                    v = u + offsets[m]
                    if state[v] & (BLOCKED | TAKEN) or (forbidden >> m) & 1:
                        continue
                    if not _sweep_free(state, u, swept, swept_count, m):
                        continue
                    vv = values[fi, v]
                    if in_goal and (vv <= vu or goal[fi, v] == 0):
                        continue  # the goal is absorbing: an agent there only moves deeper into it
                    if vv > vu:
                        cand[n0] = m
                        cand_val[n0] = vv
                        n0 += 1
                    else:
                        n1 += 1
                        cand[n_moves + 1 - n1] = m
                        cand_val[n_moves + 1 - n1] = vv
                if in_goal and n0 == 0:  # nowhere deeper: stay
                    state[u] |= TAKEN
                    continue
                if n0 > 0:
                    lo, hi = 0, n0
                else:  # neighbors1 plus staying put
                    n1 += 1
                    cand[n_moves + 1 - n1] = stay
                    cand_val[n_moves + 1 - n1] = vu
                    lo, hi = n_moves + 1 - n1, n_moves + 1
                vmax = -np.inf
                for c in range(lo, hi):
                    if cand_val[c] > vmax:
                        vmax = cand_val[c]
                pick = stay
                picked = vu
                if vmax > -np.inf:
                    total = 0.0
                    for c in range(lo, hi):  # eq. (4); exp(0) = 1 needs no call
                        weight[c] = 1.0 if cand_val[c] == vmax else np.exp((cand_val[c] - vmax) / tau)
                        total += weight[c]
                    r = uniforms[step, i] * total
                    acc = 0.0
                    pick = cand[hi - 1]
                    picked = cand_val[hi - 1]
                    for c in range(lo, hi):
                        acc += weight[c]
                        if r < acc and cand_val[c] > -np.inf:
                            pick = cand[c]
                            picked = cand_val[c]
                            break
                if pick < stay:
                    move_of[i] = pick
                    u += offsets[pick]
                    for k in range(dim):
                        coord[i, k] += np.int64(move_vec[pick, k])
                cur[i] = u
                keys[i] = -picked
                state[u] |= TAKEN
        for i in range(n):  # the start cells of the next step
            if move_of[i] != stay:
                start = cur[i] - offsets[move_of[i]]
                if occ[start] == i:
                    occ[start] = -1
                    state[start] &= ~STARTED
        for i in range(n):
            if active[i] and move_of[i] != stay:
                occ[cur[i]] = i
                state[cur[i]] |= STARTED
            elif not active[i] and occ[cur[i]] == i:
                occ[cur[i]] = -1
                state[cur[i]] &= ~STARTED
            for k in range(dim):
                out[step, i, k] = coord[i, k] - PAD
    return out
