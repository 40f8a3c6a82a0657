"""Collision-aware smoothing of a run's paths at the frame rate a character plays them
(our term, not a paper's: ``MDPParams.smoothing = "relaxed"``).

A grid method's path is a string of cell centres, one per step: it zig-zags between the
8 (26) move directions, stops and starts, and turns by 45° at a cell centre. A spline
through the centres rounds each corner a little, but a spline smooth enough for a
character (acceleration, turn rate and wobble of a walk) leaves the cell centres by up to
half a cell, and with it the plan's clearance from the other agents and the walls. Here
the paths are *relaxed* instead, in space-time and all agents at once:

1. the plan at the output rate (straight moves between the step's cell centres: every
   frame clear, as the plan is);
2. repeat ``iterations`` times: move every frame of every agent part of the way to its
   moving average over ``window_s`` seconds (three passes of a box window, which is a
   quadratic B-spline kernel; the window shrinks near an agent's first and last frame,
   which stay where the plan has them), then push apart, frame by frame, every two
   bodies nearer than their radii and ``margin`` and push every body out of the
   obstacles it comes nearer than its radius and ``margin`` (at that frame's time, so
   moving obstacles count where they are).

Each round starts from frames that are (nearly) clear and moves them a little, so the
pushes stay small and the paths converge to smooth ones that keep their distance; no
agent is ever stopped or turned back (there is no time order to deadlock in). What is
left is checked in continuous time by the caller (:func:`crowdmotion.smoothing.keep_clean`):
any frame interval still overlapping falls back to the plan's straight move there.
"""

from __future__ import annotations

import warnings

import numpy as np
from numba import njit, prange

from crowdmotion.scene import Box, Polygon, Scene, _Round

PASSES = 3  # box passes of the moving average: a quadratic B-spline kernel (C¹ weights)


@njit(cache=True, parallel=True)
def smooth_toward_average(X, first, last, half, passes, weight):
    """Move each frame of each agent ``weight`` of the way to its moving average over
    frames f - w .. f + w, taken ``passes`` times over, where w = min(``half``, f - first[i],
    last[i] - f): the window shrinks to nothing at an agent's first and last frame, which
    keep their place. Frames outside first[i] .. last[i] are left as they are."""
    T, N, D = X.shape
    for i in prange(N):
        a, b = first[i], last[i]
        if b - a < 2:
            continue
        m = b - a + 1
        cur = np.empty((m, D))
        buf = np.empty((m + 1, D))
        for f in range(m):
            for d in range(D):
                cur[f, d] = X[a + f, i, d]
        for _ in range(passes):
            for d in range(D):
                buf[0, d] = 0.0
            for f in range(m):
                for d in range(D):
                    buf[f + 1, d] = buf[f, d] + cur[f, d]
            for f in range(m):
                w = min(half, f, m - 1 - f)
                for d in range(D):
                    cur[f, d] = (buf[f + w + 1, d] - buf[f - w, d]) / (2 * w + 1)
        for f in range(m):
            for d in range(D):
                X[a + f, i, d] += weight * (cur[f, d] - X[a + f, i, d])


@njit(cache=True)
def _bin_frame(X, f, idx, k, h, cell, items):
    """Counting sort of the ``k`` bodies ``idx`` of frame ``f`` into a uniform grid of cell
    ≥ ``h`` over their bounding box on the first two axes (wider cells in a sparse frame,
    at most 4k + 16 of them): fills ``cell`` (each body's cell) and ``items`` (the bodies,
    cell by cell); returns (the cells' starts into ``items``, the grid's nx, ny)."""
    lox, loy, hix, hiy = np.inf, np.inf, -np.inf, -np.inf
    for a in range(k):
        i = idx[a]
        lox, hix = min(lox, X[f, i, 0]), max(hix, X[f, i, 0])
        loy, hiy = min(loy, X[f, i, 1]), max(hiy, X[f, i, 1])
    hf = h
    nx, ny = int((hix - lox) / hf) + 1, int((hiy - loy) / hf) + 1
    while nx * ny > 4 * k + 16:  # a sparse frame: fewer, wider cells
        hf = hf * 1.5
        nx, ny = int((hix - lox) / hf) + 1, int((hiy - loy) / hf) + 1
    start = np.zeros(nx * ny + 1, np.int64)
    for a in range(k):
        i = idx[a]
        cell[a] = min(int((X[f, i, 0] - lox) / hf), nx - 1) * ny + min(int((X[f, i, 1] - loy) / hf), ny - 1)
        start[cell[a] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    for a in range(k):
        items[fill[cell[a]]] = idx[a]
        fill[cell[a]] += 1
    return start, nx, ny


@njit(cache=True, parallel=True)
def separate(X, active, radius, margin, h, sweeps):
    """Push apart, in each frame, every two active bodies nearer than r_i + r_j + ``margin``
    (each by half the shortfall, along the line between them; Jacobi sweeps over a
    uniform grid of cell ``h`` ≥ the largest r_i + r_j + margin on the first two axes).
    Returns the number of pushes made."""
    T, N, D = X.shape
    pushes = np.zeros(T, np.int64)
    for f in prange(T):
        idx = np.empty(N, np.int64)
        k = 0
        for i in range(N):
            if active[f, i]:
                idx[k] = i
                k += 1
        if k < 2:
            continue
        push = np.zeros((N, D))
        cell = np.empty(k, np.int64)
        items = np.empty(k, np.int64)
        for _ in range(sweeps):
            start, nx, ny = _bin_frame(X, f, idx, k, h, cell, items)
            touched = 0
            for a in range(k):
                i = idx[a]
                cx, cy = cell[a] // ny, cell[a] % ny
                for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                    for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
                        c = gx * ny + gy
                        for s in range(start[c], start[c + 1]):
                            j = items[s]
                            if j <= i:
                                continue
                            d2 = 0.0
                            for d in range(D):
                                d2 += (X[f, j, d] - X[f, i, d]) ** 2
                            need = radius[i] + radius[j] + margin
                            if d2 >= need * need or d2 == 0.0:
                                continue
                            dist = np.sqrt(d2)
                            corr = 0.5 * (need - dist) / dist
                            for d in range(D):
                                u = (X[f, j, d] - X[f, i, d]) * corr
                                push[i, d] -= u
                                push[j, d] += u
                            touched += 1
            if touched == 0:
                break
            pushes[f] += touched
            for a in range(k):
                i = idx[a]
                for d in range(D):
                    X[f, i, d] += push[i, d]
                    push[i, d] = 0.0
    return pushes.sum()


@njit(cache=True, parallel=True)
def separate_swept(X, active, radius, margin, h, sweeps):
    """Push apart every two bodies whose straight moves between frames f and f + 1 bring
    them nearer than r_i + r_j + ``margin`` (the continuous-time audit's view of a frame
    interval, where :func:`separate` sees the frames alone): at the pair's closest
    approach, at the share u of the interval, each body moves by half the shortfall
    along the line between them, frame f by (1 - u) of it and frame f + 1 by u. Even
    intervals, then odd ones (so that no two at once move one frame), each up to
    ``sweeps`` times; a uniform grid of cell ≥ ``h`` plus the longest move on the first two
    axes. Returns the number of pushes made."""
    T, N, D = X.shape
    pushes = np.zeros(T, np.int64)
    for parity in range(2):
        for f in prange(T - 1):
            if f % 2 != parity:
                continue
            idx = np.empty(N, np.int64)
            k = 0
            for i in range(N):
                if active[f, i] and active[f + 1, i]:
                    idx[k] = i
                    k += 1
            if k < 2:
                continue
            push0 = np.zeros((N, D))
            push1 = np.zeros((N, D))
            cell = np.empty(k, np.int64)
            items = np.empty(k, np.int64)
            for _ in range(sweeps):
                move = 0.0
                for a in range(k):
                    i = idx[a]
                    m2 = 0.0
                    for d in range(D):
                        m2 += (X[f + 1, i, d] - X[f, i, d]) ** 2
                    move = max(move, np.sqrt(m2))
                hf = h + move
                start, nx, ny = _bin_frame(X, f, idx, k, hf, cell, items)
                touched = 0
                for a in range(k):
                    i = idx[a]
                    cx, cy = cell[a] // ny, cell[a] % ny
                    for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                        for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
                            c = gx * ny + gy
                            for s in range(start[c], start[c + 1]):
                                j = items[s]
                                if j <= i:
                                    continue
                                # relative position r(u) = r0 + u (r1 - r0), u in [0, 1]
                                rd = 0.0
                                dd = 0.0
                                for d in range(D):
                                    r0 = X[f, j, d] - X[f, i, d]
                                    e = (X[f + 1, j, d] - X[f + 1, i, d]) - r0
                                    rd += r0 * e
                                    dd += e * e
                                u = 0.0 if dd <= 0.0 else min(max(-rd / dd, 0.0), 1.0)
                                q2 = 0.0
                                for d in range(D):
                                    r0 = X[f, j, d] - X[f, i, d]
                                    q2 += (r0 + u * ((X[f + 1, j, d] - X[f + 1, i, d]) - r0)) ** 2
                                need = radius[i] + radius[j] + margin
                                if q2 >= need * need or q2 == 0.0:
                                    continue
                                dist = np.sqrt(q2)
                                corr = 0.5 * (need - dist) / dist
                                for d in range(D):
                                    r0 = X[f, j, d] - X[f, i, d]
                                    w = (r0 + u * ((X[f + 1, j, d] - X[f + 1, i, d]) - r0)) * corr
                                    push0[i, d] -= (1.0 - u) * w
                                    push0[j, d] += (1.0 - u) * w
                                    push1[i, d] -= u * w
                                    push1[j, d] += u * w
                                touched += 1
                if touched == 0:
                    break
                pushes[f] += touched
                for a in range(k):
                    i = idx[a]
                    for d in range(D):
                        X[f, i, d] += push0[i, d]
                        X[f + 1, i, d] += push1[i, d]
                        push0[i, d] = 0.0
                        push1[i, d] = 0.0
    return pushes.sum()


@njit(cache=True)
def _box_gap(px, py, lx, ly, ux, uy):
    """Signed distance of the point (px, py) from the box [lx, ux] x [ly, uy] and the unit
    direction away from it there."""
    cx, cy = min(max(px, lx), ux), min(max(py, ly), uy)
    dx, dy = px - cx, py - cy
    out = np.sqrt(dx * dx + dy * dy)
    if out > 0.0:
        return out, dx / out, dy / out
    best, nx, ny = lx - px, -1.0, 0.0  # inside: the nearest side
    if px - ux > best:
        best, nx, ny = px - ux, 1.0, 0.0
    if ly - py > best:
        best, nx, ny = ly - py, 0.0, -1.0
    if py - uy > best:
        best, nx, ny = py - uy, 0.0, 1.0
    return best, nx, ny


@njit(cache=True, parallel=True)
def push_moves_out_of_obstacles(X, active, radius, margin, kind, lower, upper, offsets):
    """Push each body whose straight move from frame f to f + 1 comes nearer than its
    radius + ``margin`` to a round or box obstacle (2D, in the obstacle's own frame)
    straight out of it: at the share u of the move where it comes nearest, frame f by
    (1 - u) and frame f + 1 by u of the shortfall, scaled so that the move clears it (the
    obstacles' twin of :func:`separate_swept`; :func:`push_out_of_obstacles` sees the
    frames alone, and moves between frames far apart cut a door's corners). Returns the
    number of pushes."""
    T, N, D = X.shape
    count = np.zeros(N, np.int64)
    if D != 2:
        return 0
    for i in prange(N):
        need = radius[i] + margin
        for f in range(T - 1):
            if not (active[f, i] and active[f + 1, i]):
                continue
            for o in range(kind.shape[0]):
                if kind[o] > 1:
                    continue
                ax, ay = X[f, i, 0] - offsets[o, f, 0], X[f, i, 1] - offsets[o, f, 1]
                bx, by = X[f + 1, i, 0] - offsets[o, f + 1, 0], X[f + 1, i, 1] - offsets[o, f + 1, 1]
                ex, ey = bx - ax, by - ay
                if kind[o] == 1 and (min(ax, bx) - need > upper[o, 0] or max(ax, bx) + need < lower[o, 0] or
                                     min(ay, by) - need > upper[o, 1] or max(ay, by) + need < lower[o, 1]):
                    continue  # the move's box, grown by the body, misses the obstacle's
                if kind[o] == 0:
                    cx, cy = lower[o, 0], lower[o, 1]
                    ee = ex * ex + ey * ey
                    u = 0.0 if ee <= 0.0 else min(max(((cx - ax) * ex + (cy - ay) * ey) / ee, 0.0), 1.0)
                    qx, qy = ax + u * ex - cx, ay + u * ey - cy
                    r = np.sqrt(qx * qx + qy * qy)
                    gap = r - upper[o, 0]
                    nx, ny = (qx / r, qy / r) if r > 0.0 else (1.0, 0.0)
                else:
                    lo, hi = 0.0, 1.0  # the gap is convex along the move: the least by golden section
                    for _ in range(40):
                        m1, m2 = lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618
                        g1 = _box_gap(ax + m1 * ex, ay + m1 * ey, lower[o, 0], lower[o, 1], upper[o, 0], upper[o, 1])[0]
                        g2 = _box_gap(ax + m2 * ex, ay + m2 * ey, lower[o, 0], lower[o, 1], upper[o, 0], upper[o, 1])[0]
                        if g1 <= g2:
                            hi = m2
                        else:
                            lo = m1
                    u = 0.5 * (lo + hi)
                    gap, nx, ny = _box_gap(ax + u * ex, ay + u * ey, lower[o, 0], lower[o, 1], upper[o, 0], upper[o, 1])
                if gap >= need:
                    continue
                if (u <= 0.0 and f > 0) or (u >= 1.0 and f + 2 < T):
                    continue  # nearest at a frame: the frame pushes (push_out_of_obstacles) see it
                scale = (need - gap) / ((1.0 - u) ** 2 + u * u)
                X[f, i, 0] += (1.0 - u) * scale * nx
                X[f, i, 1] += (1.0 - u) * scale * ny
                X[f + 1, i, 0] += u * scale * nx
                X[f + 1, i, 1] += u * scale * ny
                count[i] += 1
    return count.sum()


@njit(cache=True, parallel=True)
def limit_steps(X, first, last, max_step, sweeps):
    """Shorten every step of agent i (frames first[i] .. last[i]) longer than
    ``max_step[i]``: its two frames move towards each other by the excess, half each (all
    of it on the inner frame next to a first or last frame, which keep their place),
    sweeping along the path up to ``sweeps`` times while any step is too long. Returns
    the number of steps shortened."""
    T, N, D = X.shape
    count = np.zeros(N, np.int64)
    for i in prange(N):
        a, b = first[i], last[i]
        step = max_step[i]
        if b - a < 2 or not step > 0.0:
            continue
        for _ in range(sweeps):
            long = 0
            for f in range(a, b):
                d2 = 0.0
                for d in range(D):
                    d2 += (X[f + 1, i, d] - X[f, i, d]) ** 2
                if d2 <= step * step:
                    continue
                dist = np.sqrt(d2)
                move_f = 0.0 if f == a else (1.0 if f + 1 == b else 0.5)  # share of the excess frame f takes
                s_f = move_f * (dist - step) / dist
                s_g = (1.0 - move_f) * (dist - step) / dist
                for d in range(D):
                    e = X[f + 1, i, d] - X[f, i, d]
                    X[f, i, d] += s_f * e
                    X[f + 1, i, d] -= s_g * e
                long += 1
            count[i] += long
            if long == 0:
                break
    return count.sum()


@njit(cache=True)
def _polygon_distance(px, py, vx, vy, n):
    """Signed distance from (px, py) to the polygon of the first ``n`` vertices (negative
    inside), and the unit vector that points out of it at the nearest boundary point."""
    best = np.inf
    gx, gy = 0.0, 0.0
    inside = False
    for k in range(n):
        ax, ay = vx[k], vy[k]
        bx, by = vx[(k + 1) % n], vy[(k + 1) % n]
        ex, ey = bx - ax, by - ay
        l2 = ex * ex + ey * ey
        t = 0.0 if l2 <= 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / l2, 0.0), 1.0)
        qx, qy = px - ax - t * ex, py - ay - t * ey
        d = np.sqrt(qx * qx + qy * qy)
        if d < best:
            best = d
            gx, gy = (qx / d, qy / d) if d > 0 else (0.0, 0.0)
        if (ay > py) != (by > py) and px < ax + (py - ay) * ex / (by - ay):
            inside = not inside
    if inside:
        return -best, -gx, -gy
    return best, gx, gy


@njit(cache=True, parallel=True)
def push_out_of_obstacles(X, active, radius, margin, kind, lower, upper, offsets, poly_x, poly_y, poly_n):
    """Move each active body that comes nearer than its radius + ``margin`` to an obstacle
    straight out of it, to that distance. Obstacle k: ``kind`` 0 round (centre ``lower[k]``,
    radius ``upper[k, 0]``), 1 box (``lower[k]`` .. ``upper[k]``), 2 polygon (2D: vertices
    ``poly_x[k], poly_y[k]``, ``poly_n[k]`` of them), each displaced by ``offsets[k, f]``
    at frame f. Returns the number of pushes."""
    T, N, D = X.shape
    count = np.zeros(T, np.int64)
    g = np.empty((T, D))
    for f in prange(T):
        for i in range(N):
            if not active[f, i]:
                continue
            need = radius[i] + margin
            for o in range(kind.shape[0]):
                sd = np.inf
                if kind[o] == 0:
                    r2 = 0.0
                    for d in range(D):
                        g[f, d] = X[f, i, d] - lower[o, d] - offsets[o, f, d]
                        r2 += g[f, d] ** 2
                    r = np.sqrt(r2)
                    sd = r - upper[o, 0]
                    if sd < need:
                        for d in range(D):
                            g[f, d] = g[f, d] / r if r > 0 else (1.0 if d == 0 else 0.0)
                elif kind[o] == 1:
                    out2 = 0.0
                    inmax = -np.inf
                    inaxis = 0
                    insign = 1.0
                    for d in range(D):
                        c = 0.5 * (lower[o, d] + upper[o, d]) + offsets[o, f, d]
                        half = 0.5 * (upper[o, d] - lower[o, d])
                        q = X[f, i, d] - c
                        e = abs(q) - half
                        if e > 0:
                            out2 += e * e
                        if e > inmax:
                            inmax, inaxis, insign = e, d, (1.0 if q >= 0 else -1.0)
                        g[f, d] = (e if e > 0 else 0.0) * (1.0 if q >= 0 else -1.0)
                    if out2 > 0:
                        sd = np.sqrt(out2)
                        if sd < need:
                            for d in range(D):
                                g[f, d] /= sd
                    else:
                        sd = inmax
                        for d in range(D):
                            g[f, d] = insign if d == inaxis else 0.0
                else:
                    sd, gx, gy = _polygon_distance(X[f, i, 0] - offsets[o, f, 0], X[f, i, 1] - offsets[o, f, 1],
                                                   poly_x[o], poly_y[o], poly_n[o])
                    g[f, 0], g[f, 1] = gx, gy
                if sd < need:
                    for d in range(D):
                        X[f, i, d] += g[f, d] * (need - sd)
                    count[f] += 1
    return count.sum()


def obstacle_arrays(scene: Scene | None, times: np.ndarray):
    """The scene's obstacles as :func:`push_out_of_obstacles` reads them, placed at ``times``,
    and its bounds as walls: a box beyond each side (a relaxed path rounding a corner by the
    scene's edge cut it, its body 1.4 cm outside the scene)."""
    obs = [] if scene is None else list(scene.obstacles) + _beyond_bounds(scene)
    dim = 2 if scene is None else scene.dim
    k = len(obs)
    vmax = max([len(o.vertices) for o in obs if isinstance(o, Polygon)] + [1])
    kind = np.zeros(k, np.int64)
    lower, upper = np.zeros((k, dim)), np.zeros((k, dim))
    offsets = np.zeros((k, len(times), dim))
    px, py, pn = np.zeros((k, vmax)), np.zeros((k, vmax)), np.zeros(k, np.int64)
    for o, ob in enumerate(obs):
        if ob.is_moving:
            offsets[o] = ob.offset(times)
        if isinstance(ob, _Round):
            kind[o], lower[o], upper[o, 0] = 0, ob.center, ob.radius
        elif isinstance(ob, Box):
            kind[o], lower[o], upper[o] = 1, ob.lower, ob.upper
        elif isinstance(ob, Polygon):
            v = ob.vertices
            kind[o], pn[o] = 2, len(v)
            px[o, :len(v)], py[o, :len(v)] = v[:, 0], v[:, 1]
        else:  # pragma: no cover - the scene knows no other shape
            raise TypeError(f"no distance for {ob!r}")
    return kind, lower, upper, offsets, px, py, pn


def _beyond_bounds(scene: Scene) -> list[Box]:
    """A box beyond each side of the scene's bounds, reaching well past the others."""
    lo, hi = np.asarray(scene.lower, float), np.asarray(scene.upper, float)
    far = float(np.max(hi - lo)) + 10.0
    walls = []
    for k in range(scene.dim):
        below_hi, above_lo = hi + far, lo - far
        below_hi[k], above_lo[k] = lo[k], hi[k]
        walls += [Box(lo - far, below_hi), Box(above_lo, hi + far)]
    return walls


def relax(positions: np.ndarray, active: np.ndarray, radius: np.ndarray, dt: float, scene: Scene | None,
          window_s: float = 1.0, iterations: int = 40, weight: float = 0.5, margin: float = 0.01,
          sweeps: int = 4, passes: int = PASSES, settle: int = 0, max_speed: np.ndarray | None = None,
          swept: bool = False) -> np.ndarray:
    """Relaxed paths (module docstring): ``positions`` (T, N, D) at ``dt`` seconds, each
    agent active over one run of frames (``active``), smoothed over ``window_s`` seconds
    by ``iterations`` rounds of averaging (``passes`` box passes, each round moving a frame
    ``weight`` of the way) and pushing bodies apart and out of obstacles to ``margin``
    metres. Then up to ``settle`` rounds of the pushes alone, until no body needs one
    (where many bodies press together, as a swarm gathered round its target does, the
    averaging of the last round leaves some nearer than ``margin``, and a round's agent
    pushes can move a body back towards an obstacle), ending on the obstacles' push.
    With ``max_speed`` (N,) m/s, each round also shortens every step that would outrun it
    (:func:`limit_steps`: the pushes can speed a body up). ``swept``: the agent pushes
    also keep bodies apart along the straight moves between frames
    (:func:`separate_swept`; frames far apart in time can be clear while the moves between
    them cross). Returns a new array."""
    X = np.array(positions, dtype=np.float64)
    act = np.ascontiguousarray(active, dtype=np.bool_)
    T, N, D = X.shape
    if T < 3 or N == 0:
        return X
    alive = act.any(axis=0)
    first = np.where(alive, np.argmax(act, axis=0), 0).astype(np.int64)
    last = np.where(alive, T - 1 - np.argmax(act[::-1], axis=0), -1).astype(np.int64)
    half = max(1, int(round(window_s / dt / (2 * passes))))  # ``passes`` boxes of 2w+1 frames span the window
    radius = np.asarray(radius, dtype=np.float64)
    h = float(2 * radius.max() + margin) if N else 1.0
    obstacles = obstacle_arrays(scene, np.arange(T) * dt)
    max_step = None if max_speed is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(max_speed, np.float64) * dt, (N,)))
    for _ in range(iterations):
        smooth_toward_average(X, first, last, half, passes, weight)
        if max_step is not None:
            limit_steps(X, first, last, max_step, sweeps)
        if len(obstacles[0]):
            push_out_of_obstacles(X, act, radius, margin, *obstacles)
        separate(X, act, radius, margin, h, sweeps)
        if swept:
            separate_swept(X, act, radius, margin, h, sweeps)
            push_moves_out_of_obstacles(X, act, radius, margin, *obstacles[:4])
    for _ in range(settle):
        slowed = 0 if max_step is None else limit_steps(X, first, last, max_step, sweeps)
        pushed = push_out_of_obstacles(X, act, radius, margin, *obstacles) if len(obstacles[0]) else 0
        apart = separate(X, act, radius, margin, h, sweeps)
        if swept:
            apart += separate_swept(X, act, radius, margin, h, sweeps)
            pushed += push_moves_out_of_obstacles(X, act, radius, margin, *obstacles[:4])
        if apart == 0 and pushed == 0 and slowed == 0:
            break
    else:
        if settle and len(obstacles[0]):
            push_out_of_obstacles(X, act, radius, margin, *obstacles)
    return X


# Relaxed paths cost about 40 rounds over every agent's every frame plus continuous audits
# of them: 2,000 agents for 384 s at 24 fps (18 million agent-frames) took 9 minutes on one
# core, and in a crowd that dense the audit's fallbacks cascade (each step put back on its
# straight move meets relaxed neighbours) until every step is straight. A run with more
# agent-frames at ``fps`` than this is relaxed at its own steps instead (one frame per step,
# STEP_RATE_ITERATIONS rounds over a window of three steps) and written at that rate: its
# players and exports resample it along the B-spline of its frames. Frames that far apart
# are kept apart along the straight moves between them (:func:`separate_swept`, the audit's
# view), within each agent's speed, and settled by up to STEP_RATE_SETTLE rounds of those
# pushes, so that no step needs to fall back.
RELAX_AT_FPS_MAX = 1_000_000
STEP_RATE_ITERATIONS = 10
STEP_RATE_SETTLE = 20


def relaxed_trajectories(traj, fps: float | None, window_s: float, scene: Scene | None, max_speed: np.ndarray,
                         margin: float = 0.01, settle: int = 0, keep_speed: bool = False, stretch: bool = False):
    """A run's :class:`~crowdmotion.trajectories.Trajectories` at ``fps`` (None: at its
    own steps), relaxed (:func:`relax`: smoothed over ``window_s`` seconds, bodies kept
    ``margin`` apart and out of the obstacles, ``settle`` rounds of pushes at the end),
    then audited in continuous time: a step where they still touch, or outrun an agent's
    ``max_speed`` (N,), keeps the run's straight move, eased in and out
    (:func:`crowdmotion.smoothing.keep_clean`). A run with more than ``RELAX_AT_FPS_MAX``
    agent-frames at ``fps`` is relaxed and kept at its own steps, its bodies kept apart
    along the straight moves between them too, within their speed, and settled (see
    ``RELAX_AT_FPS_MAX``). ``metadata["relaxed"]`` says which, and
    ``metadata["resampled"]`` how many steps fell back. ``keep_speed``: the relaxation
    itself keeps every agent within its ``max_speed`` (or its own fastest step, where that
    is faster), so that few steps need to fall back for speed. ``stretch``: where the relaxed
    paths (or the run's own moves the audit puts back) are faster than an agent's
    ``max_speed``, the whole run is played that many times slower before the audit
    (``metadata["slowed_by"]``), so that no agent outruns its ``max_speed``."""
    from crowdmotion.smoothing import keep_clean, speed_limits
    from crowdmotion.trajectories import Trajectories, resample

    rate = 1.0 / traj.dt if fps is None else fps
    at_fps = traj.n_agents * (int((traj.n_frames - 1) * traj.dt * rate) + 1)  # agent-frames at fps
    by_steps = fps is None or at_fps > RELAX_AT_FPS_MAX
    linear = traj if by_steps else resample(traj, fps, "linear")
    if traj.n_frames < 2:
        return linear
    top = None
    if keep_speed or (by_steps and fps is not None):  # a hair under the audit's limit (keep_clean): the settling pushes may add a little
        top = 0.999 * speed_limits(traj, max_speed)
    if by_steps and fps is not None:  # a run this large: minutes saved, see RELAX_AT_FPS_MAX
        pos = relax(traj.positions, traj.active_mask, traj.radius, traj.dt, scene, window_s,
                    iterations=STEP_RATE_ITERATIONS, passes=1, margin=margin, settle=max(settle, STEP_RATE_SETTLE),
                    max_speed=top, swept=True)
    else:
        pos = relax(linear.positions, linear.active_mask, traj.radius, linear.dt, scene, window_s, margin=margin,
                    settle=settle, max_speed=top)
    smooth = Trajectories(pos, linear.dt, ids=linear.ids, group=linear.group, radius=linear.radius,
                          active=linear.active, metadata={**linear.metadata}, stage=linear.stage)
    # stretch: the relaxed paths' own top speed sets the time base; a step the audit puts back
    # on the run's own move can be faster still (a diagonal), and then the run is slowed
    # that much more and audited again; the last try slows it for the run's own steps too
    ratio = _fastest(smooth, max_speed) if stretch else 0.0
    for attempt in range(STRETCH_TRIES + 1):
        if attempt == STRETCH_TRIES:
            ratio = max(ratio, _fastest(traj, max_speed))
        played = _played_slower(smooth, linear, traj, ratio, by_steps)
        out = keep_clean(*played, scene, max_speed, "relaxed", warn=False)
        more = _fastest(out, max_speed) if stretch else 0.0
        if more <= 1.0 + 1e-9:
            break
        ratio = max(ratio, 1.0) * more
    linear = played[1]
    out.metadata["relaxed"] = {"at": "steps" if by_steps else "fps", "fps": 1.0 / linear.dt,
                               "agent_frames_at_fps": at_fps, "limit": RELAX_AT_FPS_MAX}
    warn_if_straight(out.metadata["resampled"])
    return out


STRETCH_TRIES = 2  # slowings of a stretched run before the last, which also fits the run's own steps


def _played_slower(smooth, linear, traj, ratio: float, by_steps: bool):
    """(smooth, linear, traj) played ``ratio`` times slower where ``ratio`` > 1 (as they are
    otherwise): at the run's steps (``by_steps``) the same frames, each lasting longer; at
    fps new frames between the old ones (:func:`crowdmotion.trajectories.slowed`), whose
    straight moves cut the old ones' corners a little, so they are audited after."""
    from crowdmotion.trajectories import Trajectories, slowed

    if ratio <= 1.0:
        return smooth, linear, traj
    traj = Trajectories(traj.positions, traj.dt * ratio, ids=traj.ids, group=traj.group, radius=traj.radius,
                        active=traj.active, metadata={**traj.metadata, "slowed_by": ratio}, stage=traj.stage)
    if by_steps:
        smooth = Trajectories(smooth.positions, traj.dt, ids=traj.ids, group=traj.group, radius=traj.radius,
                              active=traj.active, metadata={**traj.metadata}, stage=traj.stage)
        return smooth, traj, traj
    return slowed(smooth, ratio), slowed(linear, ratio), traj


def _fastest(traj, max_speed: np.ndarray) -> float:
    """The largest ratio of an agent's step speed to its ``max_speed`` in ``traj``."""
    ok = traj.active_mask[:-1] & traj.active_mask[1:]
    return float(np.max(np.where(ok, traj.speed[:-1] / max_speed[None, :], 0.0), initial=0.0))


# A relaxation that leaves more than this share of the path steps on the plan's own moves
# has not smoothed the run: the user is told, not left to find it in the pictures
STRAIGHT_WARN_SHARE = 0.1


def warn_if_straight(done: dict) -> None:
    """Warn when the continuous audit put back more than ``STRAIGHT_WARN_SHARE`` of the
    path steps (``done``: ``straight_segments`` of ``segments``) on their straight moves."""
    n, total = int(done.get("straight_segments") or 0), int(done.get("segments") or 0)
    if total and n > STRAIGHT_WARN_SHARE * total:
        warnings.warn(f"relaxed smoothing kept the plan's straight moves on {n} of {total} path steps "
                      f"({100 * n / total:.0f} %): relaxed paths would bring bodies together there (a crowd "
                      f"pressed this close), so characters bound to them turn and stop sharply; summary.json's "
                      f"root_motion says how much", UserWarning, stacklevel=3)


# A simulated run's own steps (the RVO method): its frames are clear and its agents already
# steer round each other, so a few rounds of the averaging and pushes smooth a dense
# crowd's stop-and-go (the wobble a character would show) without settling rounds: the
# 2,000-person stand evacuation's 2.2 million agent-steps take about 1 s, and its audit a
# few seconds more.
SIM_STEP_ITERATIONS = 4


def relaxed_steps(traj, window_s: float, scene: Scene | None, max_speed: np.ndarray,
                  iterations: int = SIM_STEP_ITERATIONS):
    """A simulated run's :class:`~crowdmotion.trajectories.Trajectories` relaxed at its own
    steps for the characters that play it: ``iterations`` rounds of moving every frame half
    way to its moving average over ``window_s`` seconds (one box) and pushing bodies apart
    and out of the obstacles (:func:`relax`), each agent within its ``max_speed`` (N,) m/s
    (or its own fastest step, where that is faster); its first and last frames stay. Then
    audited in continuous time: a step where bodies touch that did not in ``traj``, or that
    outruns ``max_speed``, keeps the run's own move, eased in and out
    (:func:`crowdmotion.smoothing.keep_clean`). An agent active over more than one run of
    frames, or that jumps (``metadata["jumps"]``: a live run's ``place()``), keeps its own
    path. ``metadata["relaxed"]`` says what was done: the window, the iterations and how
    many path steps (``straight_segments`` of ``segments``) kept their own move; more
    than ``STRAIGHT_WARN_SHARE`` of them gives a warning (:func:`warn_if_straight`)."""
    from crowdmotion.smoothing import keep_clean, speed_limits
    from crowdmotion.trajectories import Trajectories

    if traj.n_frames < 3 or traj.n_agents == 0:
        return traj
    act = traj.active_mask
    top = 0.999 * speed_limits(traj, max_speed)  # a hair under the audit's limit, as above
    pos = relax(traj.positions, act, traj.radius, traj.dt, scene, window_s, iterations=iterations, passes=1,
                max_speed=top)
    runs = act[0].astype(int) + (act[1:] & ~act[:-1]).sum(axis=0)
    broken = runs > 1  # relax assumes one run of frames: these keep their own paths
    for _, i in traj.jump_steps():  # and one unbroken path: an agent placed elsewhere keeps its own
        broken[i] = True
    pos[:, broken] = traj.positions[:, broken]
    smooth = Trajectories(pos, traj.dt, ids=traj.ids, group=traj.group, radius=traj.radius, active=traj.active,
                          metadata={**traj.metadata})
    out = keep_clean(smooth, traj, traj, scene, max_speed, "relaxed", warn=False)
    out.stage = traj.stage  # the same frames: each agent in the same stage
    # nothing was resampled: the audit's count goes with the relaxation, where a later
    # resampling (an export at 24 fps) does not overwrite it
    done = out.metadata.pop("resampled")
    if "resampled" in traj.metadata:
        out.metadata["resampled"] = traj.metadata["resampled"]
    out.metadata["relaxed"] = {"at": "steps", "fps": 1.0 / traj.dt, "window_s": float(window_s),
                               "iterations": iterations, "straight_segments": done["straight_segments"],
                               "segments": done["segments"]}
    warn_if_straight(done)
    return out
