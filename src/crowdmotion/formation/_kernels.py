"""Numba kernels of the formation step: the per-triangle fitting of step 2 (fused with
its right-hand side), local agent repulsion over the contact grid, pushing vertices apart
over the same grid, edge-length error."""

from __future__ import annotations

import numpy as np
from numba import njit

from crowdmotion._contact import grid_neighbours, max_cell


@njit(cache=True)
def fit_elements(rest, z, el, rhs, sums, counts, accumulate_edges):
    """Step 2a for every element: the congruent copy of its rest element (rotation and
    translation, least squares) nearest to the intermediate positions ``z``.

    With ``accumulate_edges`` adds each fitted edge difference to ``rhs`` (the right-hand
    side of eq. (1)'s normal equations: +d at the edge's first vertex, −d at the other);
    otherwise adds the fitted positions to ``sums`` and counts to ``counts`` (for the
    averaging variant). ``rest`` (e, 3) and ``z`` (n,) are complex.
    """
    for e in range(el.shape[0]):
        a, b, c = el[e, 0], el[e, 1], el[e, 2]
        cr = (rest[e, 0] + rest[e, 1] + rest[e, 2]) / 3.0
        cz = (z[a] + z[b] + z[c]) / 3.0
        s = (np.conj(rest[e, 0] - cr) * (z[a] - cz) + np.conj(rest[e, 1] - cr) * (z[b] - cz)
             + np.conj(rest[e, 2] - cr) * (z[c] - cz))
        m = abs(s)
        rot = s / m if m > 0 else 1.0 + 0.0j
        f0 = cz + rot * (rest[e, 0] - cr)
        f1 = cz + rot * (rest[e, 1] - cr)
        f2 = cz + rot * (rest[e, 2] - cr)
        if accumulate_edges:
            d = f0 - f1
            rhs[a] += d
            rhs[b] -= d
            d = f1 - f2
            rhs[b] += d
            rhs[c] -= d
            d = f2 - f0
            rhs[c] += d
            rhs[a] -= d
        else:
            sums[a] += f0
            sums[b] += f1
            sums[c] += f2
            counts[a] += 1
            counts[b] += 1
            counts[c] += 1


@njit(cache=True)
def repulsion(who, pos, radius, reach, speed, start, items, origin_x, origin_y, h, nx, ny, out):
    """Local repulsion F_r on agents ``who``: from every agent whose gap (distance minus
    both radii) is below ``reach``, (1 − gap/reach) × ``speed`` straight away from it.
    The grid (from :func:`crowdmotion._contact.grid_for`) must have cells of at least
    2·max radius + reach."""
    buf = np.empty(9 * max_cell(start), np.int64)
    for s in range(who.shape[0]):
        i = who[s]
        px, py = pos[i, 0], pos[i, 1]
        fx, fy = 0.0, 0.0
        for k in range(grid_neighbours(i, pos, start, items, origin_x, origin_y, h, nx, ny, buf)):
            j = buf[k]
            dx, dy = px - pos[j, 0], py - pos[j, 1]
            d = np.sqrt(dx * dx + dy * dy)
            gap = d - radius[i] - radius[j]
            if gap < reach and d > 0:
                w = (1.0 - max(gap, 0.0) / reach) * speed
                fx += w * dx / d
                fy += w * dy / d
        out[s, 0] = fx
        out[s, 1] = fy


@njit(cache=True)
def spread_push(pos, need, start, items, origin_x, origin_y, h, nx, ny, out):
    """For every point, the sum over the points nearer than ``need`` of half the
    shortfall, straight away from each (coincident points push nothing), into ``out``
    (n, 2); returns how many (ordered) pairs were too near. The grid
    (:func:`crowdmotion._contact.build_grid`) must have cells of at least ``need``.
    Serial: threads did not pay on two cores (16 ms against 8 at 100,000 points)."""
    buf = np.empty(9 * max_cell(start), np.int64)
    count = 0
    for i in range(pos.shape[0]):
        px, py = pos[i, 0], pos[i, 1]
        fx, fy = 0.0, 0.0
        for k in range(grid_neighbours(i, pos, start, items, origin_x, origin_y, h, nx, ny, buf)):
            j = buf[k]
            dx, dy = px - pos[j, 0], py - pos[j, 1]
            d = np.sqrt(dx * dx + dy * dy)
            if d < need:
                count += 1
                if d > 0:
                    w = 0.5 * (need - d) / d
                    fx += w * dx
                    fy += w * dy
        out[i, 0] = fx
        out[i, 1] = fy
    return count


@njit(cache=True)
def edge_length_error(points, edges, rest_length):
    """Mean and max of |‖p_i − p_j‖ / rest − 1| over the edges."""
    m = edges.shape[0]
    if m == 0:
        return 0.0, 0.0
    tot = 0.0
    worst = 0.0
    for k in range(m):
        i, j = edges[k, 0], edges[k, 1]
        dx = points[i, 0] - points[j, 0]
        dy = points[i, 1] - points[j, 1]
        d = np.sqrt(dx * dx + dy * dy)
        e = abs(d / rest_length[k] - 1.0)
        tot += e
        worst = max(worst, e)
    return tot / m, worst
