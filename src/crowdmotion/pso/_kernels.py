"""Numba kernels of the particle-swarm iteration (2D and 3D, many swarms at once).

State lives in flat arrays over all particles of all swarms: positions ``x`` (N, D),
velocities ``v``, personal bests ``pb`` and their distances ``pbd``, the swarm of each
particle ``gid`` and per-swarm arrays (G, D) for the best position ``gb`` and target.
The Python side (:mod:`crowdmotion.pso.swarm`) owns the state and calls, per iteration:

1. :func:`propose_velocities` — the canonical update, in parallel;
2. :func:`avoid_and_commit` — the paper's redirect rule (eqs. 4–5) against obstacles and
   other particles, processed nearest-to-target first, then the final separation step
   (sequential: each particle sees the moves of those processed before it);
3. :func:`update_bests` — personal and swarm bests, arrival by threshold.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from crowdmotion._rng import uniform
from crowdmotion._threads import threaded

# agents keep this much more than the sum of radii (metres) so that float rounding in the
# audit never reads a touch as an overlap
CONTACT_EPS = 1e-7
# counters filled by avoid_and_commit
OBSTACLE_REDIRECTS, DEGENERATE, AGENT_REDIRECTS, RULE_CONFLICTS, TRUNCATED, SEPARATION_STOPS, \
    OBSTACLE_STOPS, JOINS = range(8)
N_COUNTERS = 8


# ---- the canonical update ---------------------------------------------------------------
@threaded
def propose_velocities(x, v, pb, gb, gid, moving, w, c1, c2, chi, vmax, key):
    """v ← χ(w·v + c1·r1·(p − x) + c2·r2·(g − x)), each component clamped to ±vmax.

    r1, r2 ~ U(0, 1) per particle and axis (counter-based: independent of threads).
    χ = 1 and w as given is the 1995 form; the constriction form has w = 1, χ < 1.
    Particles that are not moving get zero velocity.
    """
    n, d = x.shape
    for i in prange(n):
        if not moving[i]:
            for a in range(d):
                v[i, a] = 0.0
            continue
        g = gid[i]
        for a in range(d):
            r1 = uniform(key, i, 2 * a)
            r2 = uniform(key, i, 2 * a + 1)
            va = chi * (w * v[i, a] + c1 * r1 * (pb[i, a] - x[i, a]) + c2 * r2 * (gb[g, a] - x[i, a]))
            if va > vmax[a]:
                va = vmax[a]
            elif va < -vmax[a]:
                va = -vmax[a]
            v[i, a] = va


@threaded
def advance_free(x, v, radius, lo, hi):
    """x ← x + v with the body kept inside the bounds (no avoidance); v becomes the move."""
    n, d = x.shape
    for i in prange(n):
        for a in range(d):
            end = min(max(x[i, a] + v[i, a], lo[a] + radius[i]), hi[a] - radius[i])
            v[i, a] = end - x[i, a]
            x[i, a] = end


@threaded
def update_bests(x, pb, pbd, gb, gbd, gid, target, moving, threshold, stopped, arrival_iter, iteration):
    """Personal best = closest position to the swarm's target so far; swarm best = best of
    those; a moving particle within ``threshold`` of its target stops."""
    n, d = x.shape
    for i in prange(n):
        g = gid[i]
        s = 0.0
        for a in range(d):
            e = x[i, a] - target[g, a]
            s += e * e
        dist = np.sqrt(s)
        if dist < pbd[i]:
            pbd[i] = dist
            for a in range(d):
                pb[i, a] = x[i, a]
        if moving[i] and dist <= threshold:
            stopped[i] = True
            arrival_iter[i] = iteration
    for i in range(n):
        g = gid[i]
        if pbd[i] < gbd[g]:
            gbd[g] = pbd[i]
            for a in range(d):
                gb[g, a] = pb[i, a]


@threaded
def target_distances(x, gid, target, out):
    n, d = x.shape
    for i in prange(n):
        s = 0.0
        for a in range(d):
            e = x[i, a] - target[gid[i], a]
            s += e * e
        out[i] = np.sqrt(s)


# ---- the redirect rule, eqs. (4)-(5) ----------------------------------------------------
@njit(cache=True)
def redirect(k, u, r1, r2, out):
    """The paper's redirect: o = m/|m| with i = k × u (4), m = u × i (5); out = |k|·o.

    m = u × (k × u) = k|u|² − u(u·k) is the part of the step k perpendicular to u, on
    k's side, in 2D and 3D alike. When k ∥ u (head-on), m vanishes: a perpendicular is
    drawn at random from (r1, r2) instead. Returns True for that degenerate case.
    """
    d = k.shape[0]
    kk = 0.0
    uu = 0.0
    ku = 0.0
    for a in range(d):
        kk += k[a] * k[a]
        uu += u[a] * u[a]
        ku += k[a] * u[a]
    knorm = np.sqrt(kk)
    if knorm == 0.0 or uu == 0.0:
        for a in range(d):
            out[a] = k[a]
        return False
    mm = 0.0
    for a in range(d):
        out[a] = k[a] * uu - u[a] * ku
        mm += out[a] * out[a]
    tol = 1e-9 * knorm * uu
    degenerate = mm <= tol * tol
    if degenerate:
        if d == 2:
            s = 1.0 if r1 < 0.5 else -1.0
            out[0] = -s * u[1]
            out[1] = s * u[0]
        else:  # a random direction, made perpendicular to u
            z = 2.0 * r1 - 1.0
            phi = 2.0 * np.pi * r2
            rho = np.sqrt(max(0.0, 1.0 - z * z))
            gx, gy, gz = rho * np.cos(phi), rho * np.sin(phi), z
            gu = gx * u[0] + gy * u[1] + gz * u[2]
            out[0] = gx * uu - u[0] * gu
            out[1] = gy * uu - u[1] * gu
            out[2] = gz * uu - u[2] * gu
            if out[0] * out[0] + out[1] * out[1] + out[2] * out[2] <= 1e-18 * uu * uu:  # g ∥ u: any other axis
                ax = 0 if abs(u[0]) <= abs(u[1]) and abs(u[0]) <= abs(u[2]) else (1 if abs(u[1]) <= abs(u[2]) else 2)
                for a in range(3):
                    out[a] = (uu if a == ax else 0.0) - u[a] * u[ax]
        mm = 0.0
        for a in range(d):
            mm += out[a] * out[a]
    scale = knorm / np.sqrt(mm)
    for a in range(d):
        out[a] *= scale
    return degenerate


# ---- obstacles: spheres/circles (sc, sr) and axis-aligned boxes (bl, bu) -----------------
@njit(inline="always")
def _box_dist(p, bl, bu, j):
    s = 0.0
    inside = True
    deepest = -np.inf
    for a in range(p.shape[0]):
        lo, hi = bl[j, a], bu[j, a]
        if p[a] < lo:
            e = lo - p[a]
            s += e * e
            inside = False
        elif p[a] > hi:
            e = p[a] - hi
            s += e * e
            inside = False
        else:
            deepest = max(deepest, max(lo - p[a], p[a] - hi))
    return deepest if inside else np.sqrt(s)


@njit(cache=True)
def _segment_box_clearance(p, k, bl, bu, j, tmp):
    """Least distance from the segment p → p + k to box j (golden-section: it is convex)."""
    lo_t, hi_t = 0.0, 1.0
    gr = 0.6180339887498949
    d = p.shape[0]
    for _ in range(60):
        t1 = hi_t - gr * (hi_t - lo_t)
        t2 = lo_t + gr * (hi_t - lo_t)
        for a in range(d):
            tmp[a] = p[a] + t1 * k[a]
        f1 = _box_dist(tmp, bl, bu, j)
        for a in range(d):
            tmp[a] = p[a] + t2 * k[a]
        f2 = _box_dist(tmp, bl, bu, j)
        if f1 < f2:
            hi_t = t2
        else:
            lo_t = t1
    best = np.inf
    for t in (0.0, 1.0, 0.5 * (lo_t + hi_t)):
        for a in range(d):
            tmp[a] = p[a] + t * k[a]
        best = min(best, _box_dist(tmp, bl, bu, j))
    return best


@njit(cache=True)
def _segment_point_distance(p, k, c, j):
    d = p.shape[0]
    kk = 0.0
    wk = 0.0
    for a in range(d):
        kk += k[a] * k[a]
        wk += (c[j, a] - p[a]) * k[a]
    t = 0.0 if kk == 0.0 else min(1.0, max(0.0, wk / kk))
    s = 0.0
    for a in range(d):
        e = p[a] + t * k[a] - c[j, a]
        s += e * e
    return np.sqrt(s)


@njit(cache=True)
def _segment_clear_listed(p, k, r, sc, sr, bl, bu, tmp, ob_items, s0, s1):
    """segment_clear over the obstacles listed in ob_items[s0:s1] (j ≥ 0 sphere, −j−1 box)."""
    for s in range(s0, s1):
        j = ob_items[s]
        if j >= 0:
            if _segment_point_distance(p, k, sc, j) < sr[j] + r:
                return False
        elif _segment_box_clearance(p, k, bl, bu, -j - 1, tmp) < r:
            return False
    return True


@njit(cache=True)
def segment_clear(p, k, r, sc, sr, bl, bu, tmp):
    """True when a body of radius r moving p → p + k keeps clear of every obstacle."""
    every = np.concatenate((np.arange(sr.shape[0]), -1 - np.arange(bl.shape[0])))
    return _segment_clear_listed(p, k, r, sc, sr, bl, bu, tmp, every, 0, every.shape[0])


@njit(inline="always")
def _cell_of(p, origin, h, dims):
    c = 0
    for a in range(p.shape[0] - 1, -1, -1):
        c = c * dims[a] + _cell_coord(p[a], origin[a], h, dims[a])
    return c


@njit(cache=True)
def _obstacle_to_avoid(p, k, r, detection, sc, sr, bl, bu, q, u, ob_items, s0, s1):
    """Of the obstacles listed in ob_items[s0:s1], the one whose detection range the next
    position p + k enters while the particle approaches it; writes u = (its closest point
    to p) − p. Returns False when there is none."""
    d = p.shape[0]
    for a in range(d):
        q[a] = p[a] + k[a]
    best = np.inf
    found = False
    for s in range(s0, s1):
        j = ob_items[s]
        if j >= 0:
            dq = 0.0
            ku = 0.0
            for a in range(d):
                e = q[a] - sc[j, a]
                dq += e * e
                ku += k[a] * (sc[j, a] - p[a])
            clear = np.sqrt(dq) - sr[j] - r
            if clear < detection and ku > 0.0 and clear < best:
                best = clear
                found = True
                for a in range(d):
                    u[a] = sc[j, a] - p[a]
        else:
            b = -j - 1
            clear = _box_dist(q, bl, bu, b) - r
            if clear < detection and clear < best:
                ku = 0.0
                for a in range(d):
                    ku += k[a] * (min(max(p[a], bl[b, a]), bu[b, a]) - p[a])
                if ku > 0.0:
                    best = clear
                    found = True
                    for a in range(d):
                        u[a] = min(max(p[a], bl[b, a]), bu[b, a]) - p[a]
    return found


# ---- uniform grid over all particles ------------------------------------------------------
@njit(inline="always")
def _cell_coord(val, origin, h, n):
    c = int((val - origin) / h)
    return 0 if c < 0 else (n - 1 if c >= n else c)


@njit(cache=True)
def build_grid(x, origin, h, dims):
    """Counting sort of all particles into cells of edge h: (cell_start, items)."""
    n, d = x.shape
    ncell = 1
    for a in range(d):
        ncell *= dims[a]
    cell_of = np.empty(n, np.int64)
    start = np.empty(ncell + 1, np.int64)  # (np.zeros and .copy() would cost a compile each)
    for c in range(ncell + 1):
        start[c] = 0
    for i in range(n):
        c = _cell_of(x[i], origin, h, dims)
        cell_of[i] = c
        start[c + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    cursor = np.empty(ncell, np.int64)
    for c in range(ncell):
        cursor[c] = start[c]
    items = np.empty(n, np.int64)
    for i in range(n):
        items[cursor[cell_of[i]]] = i
        cursor[cell_of[i]] += 1
    return start, items


@njit(cache=True)
def _near(p, x, origin, h, dims, start, items, reach, buf):
    """Indices j with |x_j − p| ≤ reach (reach ≤ h), into buf; returns the count."""
    d = p.shape[0]
    cx = _cell_coord(p[0], origin[0], h, dims[0])
    cy = _cell_coord(p[1], origin[1], h, dims[1])
    cz = _cell_coord(p[2], origin[2], h, dims[2]) if d == 3 else 0
    zr = 1 if d == 3 else 0
    cnt = 0
    r2 = reach * reach
    for oz in range(-zr, zr + 1):
        z = cz + oz
        if d == 3 and (z < 0 or z >= dims[2]):
            continue
        for oy in range(-1, 2):
            y = cy + oy
            if y < 0 or y >= dims[1]:
                continue
            for ox in range(-1, 2):
                xx = cx + ox
                if xx < 0 or xx >= dims[0]:
                    continue
                c = xx + dims[0] * (y + (dims[1] * z if d == 3 else 0))
                for s in range(start[c], start[c + 1]):
                    j = items[s]
                    dd = 0.0
                    for a in range(d):
                        e = x[j, a] - p[a]
                        dd += e * e
                    if dd <= r2:
                        buf[cnt] = j
                        cnt += 1
    return cnt


# ---- continuous-time contact with the particles already placed ---------------------------
@njit(cache=True)
def _first_contact(i, p, k, x, newx, radius, nb, cnt):
    """Earliest fraction t ∈ [0, 1] of the step at which i, moving p → p + k, touches a
    neighbour (j moving x_j → newx_j over the same step; unprocessed ones have newx = x);
    2 when there is no contact."""
    d = p.shape[0]
    best_t = 2.0
    for s in range(cnt):
        j = nb[s]
        if j == i:
            continue
        rr = radius[i] + radius[j] + CONTACT_EPS
        a2 = 0.0
        b = 0.0
        c = 0.0
        for a in range(d):
            w0 = p[a] - x[j, a]
            dw = k[a] - (newx[j, a] - x[j, a])
            a2 += dw * dw
            b += w0 * dw
            c += w0 * w0
        c -= rr * rr
        if c <= 0.0:  # touching already: only a move that opens the gap is allowed
            if b < 0.0:
                best_t = 0.0
            continue
        if a2 == 0.0 or b >= 0.0:
            continue
        disc = b * b - a2 * c
        if disc <= 0.0:
            continue
        t = (-b - np.sqrt(disc)) / a2
        if t <= 1.0 and t < best_t:
            best_t = t
    return best_t


@njit(cache=True)
def _agent_to_avoid(i, p, k, newx, nb, cnt, avoid_radius, cos_theta, u):
    """The agent rule: of the neighbours nb[:cnt] (at their new positions), the nearest
    within ``avoid_radius`` whose direction lies within θ of the step k (cos θ =
    ``cos_theta``); writes u = its position − p. Returns False when there is none."""
    d = p.shape[0]
    kk = 0.0
    for a in range(d):
        kk += k[a] * k[a]
    kn = np.sqrt(kk)
    best = np.inf
    bj = -1
    for s in range(cnt):
        j = nb[s]
        if j == i:
            continue
        dd = 0.0
        dot = 0.0
        for a in range(d):
            e = newx[j, a] - p[a]
            dd += e * e
            dot += e * k[a]
        dist = np.sqrt(dd)
        if dist < avoid_radius and dist < best and kn > 0.0 and dot >= cos_theta * dist * kn:
            best = dist
            bj = j
    if bj < 0:
        return False
    for a in range(d):
        u[a] = newx[bj, a] - p[a]
    return True


@njit(cache=True)
def _separate(i, p, k, x, newx, radius, nb, cnt, counters):
    """The separation guard: the step k cut short before its first contact with a
    neighbour (else set to zero); returns whether it had to be cut."""
    t = _first_contact(i, p, k, x, newx, radius, nb, cnt)
    if t > 1.0:
        return False
    counters[RULE_CONFLICTS] += 1
    shrink = max(0.0, t * (1.0 - 1e-6) - 1e-9)
    for a in range(k.shape[0]):
        k[a] *= shrink
    if shrink > 0.0 and _first_contact(i, p, k, x, newx, radius, nb, cnt) > 1.0:
        counters[TRUNCATED] += 1
    else:
        counters[SEPARATION_STOPS] += 1
        for a in range(k.shape[0]):
            k[a] = 0.0
    return True


@njit(cache=True)
def _touches_gathered(i, newx, radius, gid, stopped, nb, cnt, join_gap):
    """Whether i, at newx[i], is within r_i + r_j + ``join_gap`` of a stopped neighbour
    of its own swarm."""
    for s in range(cnt):
        j = nb[s]
        if j == i or not stopped[j] or gid[j] != gid[i]:
            continue
        dd = 0.0
        for a in range(newx.shape[1]):
            e = newx[j, a] - newx[i, a]
            dd += e * e
        reach = radius[i] + radius[j] + join_gap
        if dd <= reach * reach:
            return True
    return False


@njit(cache=True)
def avoid_and_commit(order, x, v, newx, radius, gid, stopped, joined, avoid_obstacles, avoid_agents,
                     separation, detection, avoid_radius, cos_theta, join_gap, target, gather_radius,
                     sc, sr, bl, bu, ob_start, ob_items, lo, hi,
                     origin, h, dims, start, items, reach, key, counters, redirected):
    """Move each particle of ``order`` (nearest to its target first) by v, after:

    1. the obstacle rule: if p + v enters an obstacle's detection range (clearance below
       ``detection``) while approaching it, v ← |v|·o, eqs. (4)–(5), with u pointing to
       the obstacle's nearest point (its centre for a sphere);
    2. the agent rule: the nearest other particle within ``avoid_radius`` whose direction
       lies within θ of v (cos θ = ``cos_theta``) is treated the same way; particles of
       the same swarm that have stopped (gathered) are the destination, not avoided;
    3. the guards that keep paths valid whatever the rules did: the body stays inside the
       bounds, the segment keeps clear of every obstacle (else the particle stays), and —
       with ``separation`` — the segment is cut short before its first contact with a
       particle already placed this iteration (or one still at its start), else it stays.

    ``newx`` must hold x on entry; it holds the new positions on return, and v the moves.
    A moving particle that ends within r_i + r_j + ``join_gap`` of a stopped particle of
    its own swarm is flagged in ``joined`` (it has gathered: the group arrival rule) when
    it is inside its swarm's ``gather_radius`` (G,) of the target, or when the separation
    step had to cut its move short (it is blocked at the edge of the gathered group).
    ``counters`` counts the rules and guards; ``redirected`` (N,) each particle's
    obstacle redirects.
    """
    n, d = x.shape
    p = np.empty(d)
    k = np.empty(d)
    u = np.empty(d)  # obstacles come from ob_start/ob_items: those near p's cell
    q = np.empty(d)
    tmp = np.empty(d)
    out = np.empty(d)
    nb = np.empty(n, np.int64)
    for oi in range(order.shape[0]):
        i = order[oi]
        for a in range(d):
            p[a] = x[i, a]
            k[a] = v[i, a]
        cnt = _near(p, x, origin, h, dims, start, items, reach, nb)
        cell = _cell_of(p, origin, h, dims)
        s0, s1 = ob_start[cell], ob_start[cell + 1]
        if avoid_obstacles and _obstacle_to_avoid(p, k, radius[i], detection, sc, sr, bl, bu, q, u, ob_items, s0, s1):
            if redirect(k, u, uniform(key, i, 100), uniform(key, i, 101), out):
                counters[DEGENERATE] += 1
            for a in range(d):
                k[a] = out[a]
            counters[OBSTACLE_REDIRECTS] += 1
            redirected[i] += 1
        if avoid_agents and _agent_to_avoid(i, p, k, newx, nb, cnt, avoid_radius, cos_theta, u):
            if redirect(k, u, uniform(key, i, 102), uniform(key, i, 103), out):
                counters[DEGENERATE] += 1
            for a in range(d):
                k[a] = out[a]
            counters[AGENT_REDIRECTS] += 1
        # guards: bounds, obstacles, other particles
        for a in range(d):
            end = min(max(p[a] + k[a], lo[a] + radius[i]), hi[a] - radius[i])
            k[a] = end - p[a] if lo[a] + radius[i] <= hi[a] - radius[i] else 0.0
        if not _segment_clear_listed(p, k, radius[i], sc, sr, bl, bu, tmp, ob_items, s0, s1):
            counters[OBSTACLE_STOPS] += 1
            for a in range(d):
                k[a] = 0.0
        cut = separation and _separate(i, p, k, x, newx, radius, nb, cnt, counters)
        for a in range(d):
            newx[i, a] = p[a] + k[a]
            v[i, a] = k[a]
        g = gid[i]
        dt2 = 0.0
        for a in range(d):
            e = newx[i, a] - target[g, a]
            dt2 += e * e
        if avoid_agents and (cut or dt2 <= gather_radius[g] * gather_radius[g]) and \
                _touches_gathered(i, newx, radius, gid, stopped, nb, cnt, join_gap):
            joined[i] = True
            counters[JOINS] += 1
