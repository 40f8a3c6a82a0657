"""Numba kernels for bodies that must not touch, shared by the continuous-space methods
(RVO, guiding-mesh formations): a uniform grid over agents, times to collision with
discs and wall segments, and the step's safety passes.

Everything works on flat float64/int64 arrays in 2D.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from crowdmotion._threads import threaded
from crowdmotion.geometry import box_of

INF = np.inf


# ---- uniform grid -----------------------------------------------------------------------
@njit(cache=True)
def build_grid(pos, active, origin_x, origin_y, h, nx, ny):
    """Counting sort of active agents into an nx × ny grid of cell edge h.

    Returns ``cell_start`` (nx·ny + 1) and ``items`` (agent indices, cell by cell).
    """
    n = pos.shape[0]
    counts = np.empty(nx * ny + 1, dtype=np.int64)  # (np.zeros, np.full and .copy() would cost a compile each)
    for c in range(nx * ny + 1):
        counts[c] = 0
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        if not active[i]:
            cell[i] = -1
            continue
        cx = min(max(int((pos[i, 0] - origin_x) / h), 0), nx - 1)
        cy = min(max(int((pos[i, 1] - origin_y) / h), 0), ny - 1)
        c = cx * ny + cy
        cell[i] = c
        counts[c + 1] += 1
    for c in range(nx * ny):
        counts[c + 1] += counts[c]
    fill = np.empty(nx * ny, dtype=np.int64)
    for c in range(nx * ny):
        fill[c] = counts[c]
    items = np.empty(counts[-1], dtype=np.int64)
    for i in range(n):
        c = cell[i]
        if c >= 0:
            items[fill[c]] = i
            fill[c] += 1
    return counts, items


# ---- time to collision ------------------------------------------------------------------
@njit(cache=True)
def _ray_disc(px, py, vx, vy, r):
    """First t ≥ 0 at which p + v·t enters the disc of radius r at the origin (0 if inside)."""
    c = px * px + py * py - r * r
    if c < 0.0:
        return 0.0
    b = px * vx + py * vy
    if b >= 0.0:
        return INF
    a = vx * vx + vy * vy
    disc = b * b - a * c
    if disc <= 0.0:
        return INF
    return (-b - np.sqrt(disc)) / a


@njit(cache=True)
def _ray_capsule(px, py, vx, vy, ax, ay, bx, by, r):
    """First t ≥ 0 at which p + v·t comes within r of the segment ab (0 if already)."""
    t = min(_ray_disc(px - ax, py - ay, vx, vy, r), _ray_disc(px - bx, py - by, vx, vy, r))
    ex, ey = bx - ax, by - ay
    l2 = ex * ex + ey * ey
    if l2 <= 0.0:
        return t
    ln = np.sqrt(l2)
    nx_, ny_ = -ey / ln, ex / ln
    qx, qy = px - ax, py - ay
    s = (qx * ex + qy * ey) / l2
    hgt = qx * nx_ + qy * ny_
    if abs(hgt) < r and 0.0 <= s <= 1.0:
        return 0.0
    hv = vx * nx_ + vy * ny_
    tt = INF  # reaching the side: from outside the band of width 2r round the line only
    if hgt >= r and hv < 0.0:
        tt = (hgt - r) / (-hv)
    elif hgt <= -r and hv > 0.0:
        tt = (-hgt - r) / hv
    if tt < t:
        s2 = ((qx + vx * tt) * ex + (qy + vy * tt) * ey) / l2
        if 0.0 <= s2 <= 1.0:
            t = tt
    return t


@njit(cache=True)
def _off_segment(px, py, ax, ay, bx, by):
    """(dx, dy): point p less the nearest point of segment ab (its outward normal times
    its distance)."""
    ex, ey = bx - ax, by - ay
    l2 = ex * ex + ey * ey
    s = 0.0 if l2 <= 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / l2, 0.0), 1.0)
    return px - ax - s * ex, py - ay - s * ey


@njit(cache=True)
def _point_segment_distance(px, py, ax, ay, bx, by):
    dx, dy = _off_segment(px, py, ax, ay, bx, by)
    return np.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def max_cell(cell_start):
    """The most agents in one cell of a grid."""
    m = 0
    for c in range(cell_start.shape[0] - 1):
        m = max(m, cell_start[c + 1] - cell_start[c])
    return m


@njit(cache=True)
def grid_neighbours(i, pos, cell_start, items, origin_x, origin_y, h, nx, ny, out):
    """Agents other than i in the 3 × 3 cells round agent i's cell, into ``out``;
    returns how many."""
    cx = min(max(int((pos[i, 0] - origin_x) / h), 0), nx - 1)
    cy = min(max(int((pos[i, 1] - origin_y) / h), 0), ny - 1)
    k = 0
    for gx in range(max(cx - 1, 0), min(cx + 1, nx - 1) + 1):
        for gy in range(max(cy - 1, 0), min(cy + 1, ny - 1) + 1):
            c = gx * ny + gy
            for s in range(cell_start[c], cell_start[c + 1]):
                if items[s] != i:
                    out[k] = items[s]
                    k += 1
    return k


@njit(cache=True)
def _conflict(i, pos, vel, radius, stopped, priority, cell_start, items, origin_x, origin_y, h, nx, ny, dt, buf):
    """Whether agent i's straight move this step would touch an agent that does not yield to it."""
    px, py = pos[i, 0], pos[i, 1]
    for s in range(grid_neighbours(i, pos, cell_start, items, origin_x, origin_y, h, nx, ny, buf)):
        j = buf[s]
        if not stopped[j] and (priority[j] < priority[i] or (priority[j] == priority[i] and j < i)):
            continue  # j yields to i
        wx, wy = pos[j, 0] - px, pos[j, 1] - py
        ux, uy = (vel[j, 0] - vel[i, 0]) * dt, (vel[j, 1] - vel[i, 1]) * dt
        proj = wx * ux + wy * uy
        if proj >= 0.0:
            continue  # not approaching
        uu = ux * ux + uy * uy
        s_ = min(-proj / uu, 1.0)
        mx, my = wx + s_ * ux, wy + s_ * uy
        rr = radius[i] + radius[j]
        if mx * mx + my * my < rr * rr * (1.0 + 1e-9):
            return True
    return False


@threaded
def resolve_conflicts(pos, vel, radius, active, priority, cell_start, items, origin_x, origin_y, h, nx, ny, dt):
    """Make agents stand still until no two would touch during this step; returns how many
    had to stop.

    Agent i must stop when its straight move would bring it closer than r_i + r_j to an
    agent j that is standing or has the higher ``priority`` (ties: the higher index). A
    parallel pass flags every such agent among the moving ones; a serial work list then
    stops them and re-examines the moving agents around each newly stopped one. Moving
    agents never change velocity, so a pair of them that did not conflict at first never
    will, and every pair with a stopped agent is examined after that agent stopped: at
    the end no pair conflicts. Positions move linearly over the step (as the continuous
    audit assumes); only approaching pairs count. ``h`` must be at least the largest
    r_i + r_j + (‖v_i‖ + ‖v_j‖)·dt so that the 3 × 3 cells around an agent suffice.
    ``vel`` is modified in place (zero for stopped agents).
    """
    n = pos.shape[0]
    flagged = np.empty(n, dtype=np.bool_)  # (np.zeros and np.flatnonzero would cost a compile each)
    stopped = np.empty(n, dtype=np.bool_)
    for i in prange(n):  # agents that chose to stand are standing: they cannot yield
        flagged[i] = False
        stopped[i] = active[i] and vel[i, 0] == 0.0 and vel[i, 1] == 0.0
    cap = 9 * max_cell(cell_start)
    chunks = 64  # each chunk of agents has its own neighbour list
    for c in prange(chunks):
        buf = np.empty(cap, np.int64)
        for i in range(c * n // chunks, (c + 1) * n // chunks):
            if active[i] and not stopped[i]:
                flagged[i] = _conflict(i, pos, vel, radius, stopped, priority, cell_start, items, origin_x,
                                       origin_y, h, nx, ny, dt, buf)
    work = []
    for i in range(n):
        if flagged[i]:
            work.append(i)
    around = np.empty(cap, np.int64)
    nbuf = np.empty(cap, np.int64)
    count = 0
    while len(work) > 0:
        j = work.pop()
        if stopped[j]:
            continue
        stopped[j] = True
        vel[j, 0] = 0.0
        vel[j, 1] = 0.0
        count += 1
        for s in range(grid_neighbours(j, pos, cell_start, items, origin_x, origin_y, h, nx, ny, around)):
            i = around[s]
            if not stopped[i] and _conflict(i, pos, vel, radius, stopped, priority, cell_start, items, origin_x,
                                            origin_y, h, nx, ny, dt, nbuf):
                work.append(i)
    return count


@njit(cache=True)
def _first_block(px, py, vx, vy, r, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, normal):
    """Whether the move (vx, vy) over dt meets an obstacle; ``normal`` gets the unit
    vector from the first obstacle met toward the agent."""
    for o in range(circ_c.shape[0]):
        t = _ray_disc(px - circ_c[o, 0], py - circ_c[o, 1], vx - circ_v[o, 0], vy - circ_v[o, 1], circ_r[o] + r)
        if t < dt * (1.0 + 1e-6):
            nx, ny = px - circ_c[o, 0], py - circ_c[o, 1]
            ln = np.sqrt(nx * nx + ny * ny)
            normal[0], normal[1] = (nx / ln, ny / ln) if ln > 0 else (0.0, 0.0)
            return True
    for o in range(seg_a.shape[0]):
        t = _ray_capsule(px, py, vx - seg_v[o, 0], vy - seg_v[o, 1], seg_a[o, 0], seg_a[o, 1], seg_b[o, 0],
                         seg_b[o, 1], r)
        if t < dt * (1.0 + 1e-6):
            nx, ny = _off_segment(px, py, seg_a[o, 0], seg_a[o, 1], seg_b[o, 0], seg_b[o, 1])
            ln = np.sqrt(nx * nx + ny * ny)
            normal[0], normal[1] = (nx / ln, ny / ln) if ln > 0 else (0.0, 0.0)
            return True
    return False


@threaded
def obstacle_safe_moves(pos, vel, radius, vmax, active, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, out_scale):
    """Change each active agent's move so that, with every obstacle moving at its own
    velocity, it does not come within its radius of one during the step.

    Tries the full move; if it meets an obstacle, the move with its part toward that
    obstacle taken away (sliding along it); then each of the two halved down to 1/16;
    then standing; then, when even standing is not safe (a moving obstacle is coming),
    fleeing at ``vmax`` away from it, straight or turned by up to ±90°. ``out_scale``
    gets the length kept over the length wanted. ``vel`` is changed in place. An agent
    with no safe choice at all stands (no pass can promise more).
    """
    n = pos.shape[0]
    for i in prange(n):
        out_scale[i] = 1.0
        if not active[i]:
            continue
        px, py, r = pos[i, 0], pos[i, 1], radius[i]
        wx, wy = vel[i, 0], vel[i, 1]
        normal = np.empty(2)
        normal[0] = 0.0
        normal[1] = 0.0
        if not _first_block(px, py, wx, wy, r, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, normal):
            continue
        want = np.sqrt(wx * wx + wy * wy)
        into = wx * normal[0] + wy * normal[1]
        tx, ty = (wx - into * normal[0], wy - into * normal[1]) if into < 0.0 else (wx, wy)
        best_x, best_y = 0.0, 0.0
        found = False
        for cx, cy in ((tx, ty), (wx, wy)):
            if cx * cx + cy * cy <= 1e-18 * want * want:
                continue  # head on: nothing to slide along
            s = 1.0
            while s > 0.05:
                if not _first_block(px, py, cx * s, cy * s, r, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v,
                                    normal):
                    best_x, best_y = cx * s, cy * s
                    found = True
                    break
                s *= 0.5
            if found:
                break
        if not found and _first_block(px, py, 0.0, 0.0, r, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, normal):
            nx, ny = normal[0], normal[1]
            for ang in (0.0, 0.7853981633974483, -0.7853981633974483, 1.5707963267948966, -1.5707963267948966):
                ca, sa = np.cos(ang), np.sin(ang)
                ex, ey = (nx * ca - ny * sa) * vmax[i], (nx * sa + ny * ca) * vmax[i]
                if not _first_block(px, py, ex, ey, r, dt, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, normal):
                    best_x, best_y = ex, ey
                    break
        vel[i, 0], vel[i, 1] = best_x, best_y
        out_scale[i] = np.sqrt(best_x * best_x + best_y * best_y) / want if want > 0 else 0.0


# ---- line of sight past obstacles (RVO guidance, formation routes) ------------------------
@njit(cache=True)
def _segments_distance(px, py, qx, qy, ax, ay, bx, by):
    """Least distance between segments pq and ab."""
    # proper intersection -> 0
    d1x, d1y = qx - px, qy - py
    d2x, d2y = bx - ax, by - ay
    den = d1x * d2y - d1y * d2x
    if den != 0.0:
        s = ((ax - px) * d2y - (ay - py) * d2x) / den
        t = ((ax - px) * d1y - (ay - py) * d1x) / den
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            return 0.0
    return min(min(_point_segment_distance(px, py, ax, ay, bx, by), _point_segment_distance(qx, qy, ax, ay, bx, by)),
               min(_point_segment_distance(ax, ay, px, py, qx, qy), _point_segment_distance(bx, by, px, py, qx, qy)))


@njit(cache=True)
def _clear(px, py, qx, qy, r, circ_c, circ_r, seg_a, seg_b):
    """Whether a body of radius r can walk straight from p to q past every obstacle."""
    for o in range(circ_c.shape[0]):
        if _point_segment_distance(circ_c[o, 0], circ_c[o, 1], px, py, qx, qy) < circ_r[o] + r:
            return False
    for o in range(seg_a.shape[0]):
        if _segments_distance(px, py, qx, qy, seg_a[o, 0], seg_a[o, 1], seg_b[o, 0], seg_b[o, 1]) < r:
            return False
    return True


@threaded
def line_of_sight(pos, goal, radius, active, circ_c, circ_r, seg_a, seg_b, out):
    """Whether the straight walk from each agent to its goal keeps clear of every obstacle."""
    n = pos.shape[0]
    for i in prange(n):
        out[i] = True if not active[i] else _clear(pos[i, 0], pos[i, 1], goal[i, 0], goal[i, 1], radius[i],
                                                   circ_c, circ_r, seg_a, seg_b)



def grid_for(positions, active, radius, max_speed, dt, extra: float = 0.0):
    """``(cell_start, items, origin_x, origin_y, h, nx, ny)``: a grid over the active
    agents with cells wide enough for :func:`resolve_conflicts` over one step (and at
    least ``extra`` metres)."""
    live = np.flatnonzero(active)
    p = positions[live]
    lo, hi = box_of(p)
    reach = max(2 * radius[live].max() + 2 * max_speed[live].max() * dt, extra)
    extent = np.maximum(hi - lo, 1e-9)
    h = max(reach, float(np.sqrt(np.prod(extent) / len(live))) * 1.5)
    while np.prod(np.floor(extent / h) + 1) > 4 * len(live) + 16:
        h *= 1.5
    nx, ny = (np.floor(extent / h) + 1).astype(np.int64)
    start, items = build_grid(positions, active, float(lo[0]), float(lo[1]), h, int(nx), int(ny))
    return start, items, float(lo[0]), float(lo[1]), float(h), int(nx), int(ny)
