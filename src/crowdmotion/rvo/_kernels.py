"""Numba kernels of the sampling RVO step: uniform grid, k nearest neighbours, time to
collision, candidate choice (paper eq. (3)), the step's safety check and guidance.

Everything here works on flat float64/int64 arrays in 2D; the Python side
(:mod:`crowdmotion.rvo.simulator`) owns the state and calls these once per step.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from crowdmotion._threads import threaded
from crowdmotion._contact import (INF, _clear, _conflict, _point_segment_distance, _ray_capsule,  # noqa: F401
                                  _ray_disc, build_grid, line_of_sight, max_cell, resolve_conflicts)
from crowdmotion._rng import uniform as _uniform

GOLDEN_COS = float(np.cos(np.pi * (3.0 - np.sqrt(5.0))))
GOLDEN_SIN = float(np.sin(np.pi * (3.0 - np.sqrt(5.0))))
# a candidate whose obstacle time to collision is below dt·(1 + SLACK) would reach the
# obstacle within the step: it is inadmissible (hard constraint)
SLACK = 1e-6
# penalty (m/s of eq. (3)'s deviation) per m/s of velocity change beyond the comfortable one,
# at steps of COMFORT_REF_S (the default step) or longer; a shorter step pays COMFORT_REF_S / dt
# times as much, so a change prices by the acceleration it takes, whatever the step (at a
# game's 30 frames a second, priced by the step's change alone, 1.9 % of the frames of
# wanderers in a plaza jolted past 5 m/s²)
COMFORT_WEIGHT = 2.0
COMFORT_REF_S = 0.25
RING = 8  # candidates on the circle of comfortable changes round the current velocity
LEAVE_LOOK_S = 1.0  # an agent counts on leaving at its goal when it would get there within this many seconds
PASS_SIDE_M = 0.5  # a parked neighbour ahead whose body comes this near our line (m) is in our way ...
PASS_BEYOND_M = 1.0  # ... and we turn this far past it (our aim, for eq. (3))
ASIDE_MPS = 0.4  # one parked steps aside this fast for a walker held in its way ...
ASIDE_AHEAD_M = 1.5  # ... standing within this gap of it (m) ...
HELD_S = 2.0  # ... that has stood this long (s)
HELD_LONG_S = 3.0  # a walker standing held up this long (s) ...
HELD_HORIZON_S = 0.5  # ... counts a neighbour's collision only when met within this many seconds
# lane choice leaves out a neighbour whose weight at every offset is below exp(−LANE_TRUNCATE)
# of its own (3e-4): a quarter of the strip's agents fewer than at 2e-16, and a quarter of the
# kernel's time, with the same choices on captured 10,000-agent steps and the same positions
# over whole runs of the narrow door, the counterflow corridor and 200 steps of the stand
LANE_TRUNCATE = 8.0
# a neighbour that wants to go over 60° off our way (cos below CROSSING_COS) is bound the other
# way when the straight lines to our goals are over 120° apart (cos below AGAINST_COS), and
# crosses our way when they are over 60° apart and its goal lies farther from ours than we are
AGAINST_COS = -0.5
CROSSING_COS = 0.5
# the choice and lane choice cost microseconds an agent, so threads pay from a few hundred
# agents on (a 300-agent circle stepped in 1.9 ms on two threads against 2.5 ms on one,
# 500 agents 2.7 against 4.0 ms), not only from the 1000 rows of cheaper kernels
PARALLEL_MIN_AGENTS = 250


@njit(cache=True)
def _knn(i, pos, m, dmax, cell_start, items, origin_x, origin_y, h, nx, ny, out_idx, out_d2):
    """The ≤ m nearest agents to i within dmax, sorted by distance; returns how many."""
    px, py = pos[i, 0], pos[i, 1]
    cx = min(max(int((px - origin_x) / h), 0), nx - 1)
    cy = min(max(int((py - origin_y) / h), 0), ny - 1)
    count = 0
    d2max = dmax * dmax
    if m <= 0:
        return 0
    ring = 0
    while True:
        x0, x1, y0, y1 = cx - ring, cx + ring, cy - ring, cy + ring
        if x0 < 0 and y0 < 0 and x1 >= nx and y1 >= ny:
            break
        for gx in range(max(x0, 0), min(x1, nx - 1) + 1):
            edge_x = gx == x0 or gx == x1
            for gy in range(max(y0, 0), min(y1, ny - 1) + 1):
                if not edge_x and gy != y0 and gy != y1:
                    continue
                c = gx * ny + gy
                for s in range(cell_start[c], cell_start[c + 1]):
                    j = items[s]
                    if j == i:
                        continue
                    dx = pos[j, 0] - px
                    dy = pos[j, 1] - py
                    d2 = dx * dx + dy * dy
                    if d2 >= d2max:
                        continue
                    if count == m and d2 >= out_d2[m - 1]:
                        continue
                    k = count if count < m else m - 1
                    while k > 0 and out_d2[k - 1] > d2:
                        out_d2[k] = out_d2[k - 1]
                        out_idx[k] = out_idx[k - 1]
                        k -= 1
                    out_d2[k] = d2
                    out_idx[k] = j
                    if count < m:
                        count += 1
        # every agent not yet seen lies outside the searched block of cells
        reach = min(min(px - (origin_x + (cx - ring) * h), origin_x + (cx + ring + 1) * h - px),
                    min(py - (origin_y + (cy - ring) * h), origin_y + (cy + ring + 1) * h - py))
        if reach >= dmax:
            break
        if count == m and reach * reach >= out_d2[m - 1]:
            break
        ring += 1
    return count


# ---- time to collision ------------------------------------------------------------------
@njit(inline="always")
def _obstacle_time(px, py, cx_, cy_, r, circ_c, circ_r, circ_v, near_c, n_near_c,
                   seg_a, seg_b, seg_v, near_s, n_near_s):
    """Least time to collision of the candidate (cx_, cy_) against the nearby obstacles:
    (against static ones, against moving ones)."""
    t_static = INF
    t_moving = INF
    for q in range(n_near_c):
        o = near_c[q]
        tt = _ray_disc(px - circ_c[o, 0], py - circ_c[o, 1], cx_ - circ_v[o, 0], cy_ - circ_v[o, 1], circ_r[o] + r)
        if circ_v[o, 0] == 0.0 and circ_v[o, 1] == 0.0:
            t_static = min(t_static, tt)
        else:
            t_moving = min(t_moving, tt)
    for q in range(n_near_s):
        o = near_s[q]
        tt = _ray_capsule(px, py, cx_ - seg_v[o, 0], cy_ - seg_v[o, 1],
                          seg_a[o, 0], seg_a[o, 1], seg_b[o, 0], seg_b[o, 1], r)
        if seg_v[o, 0] == 0.0 and seg_v[o, 1] == 0.0:
            t_static = min(t_static, tt)
        else:
            t_moving = min(t_moving, tt)
    return t_static, t_moving


# error_model "numpy": the candidates' loops without branches divide where the result is then
# discarded (vm / sp at sp = 0); raising there would keep the compiler from vectorising them
@threaded(min_items=PARALLEL_MIN_AGENTS, error_model="numpy")
def choose_velocities(pos, vel, vpref, aim_dist, radius, vmax, max_nb, nb_dist, samples, safety, active,
                      cell_start, items, origin_x, origin_y, h, nx, ny,
                      circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, dt, key,
                      out_vel, out_forced, keep_right, look_s, follow, comfort, goals, leave_r, squeeze_s, squeeze_side,
                      parked, still, held_s):
    """Sampling RVO for every active agent at once (simultaneous, order-independent).

    For agent i the candidates are v_pref, the current velocity, standing still and
    ``samples[i]`` random velocities in the disc of radius ``vmax[i]`` (stratified: a
    randomly turned and shifted sunflower pattern). For each
    candidate v′, tc is the least time to collision over the ≤ M nearest neighbours within
    D — along the reciprocal velocity 2v′ − v_i − v_j against the disc r_i + r_j — and over
    obstacles along v′ (relative to the obstacle's own velocity); an obstacle that v′ would
    reach only after covering ``aim_dist`` — the distance to the goal, or to the next
    visible way-point of the guidance field — does not count: the agent stops or turns
    there, so a wall behind that point is no threat. The choice minimises
    penalty(v′) = w_i / tc(v′) + ‖v_pref − v′‖ (paper eq. (3); tc = ∞ gives 0) among the
    candidates that reach no obstacle within the step. If none qualifies (a moving obstacle
    bearing down) the choice is forced: the least penalty among candidates that at least
    keep out of static obstacles (standing still always does). Writes ``out_vel`` and
    whether the choice was forced.

    Comfortable acceleration (a documented addition, ``comfort[i]`` m/s per step, 0 =
    off): a candidate changing the velocity by more than ``comfort[i]`` costs
    ``COMFORT_WEIGHT`` × max(1, ``COMFORT_REF_S`` / dt) per m/s beyond it on top of eq.
    (3)'s penalty: by the excess acceleration, priced at any step as at the default
    0.25 s one. The candidates then
    also hold the comfortable change towards v_pref and ``RING`` comfortable changes all
    round the current velocity.

    Leaving on arrival (a documented addition): an agent removed once within
    ``leave_r[i]`` of its goal ``goals[i]`` (``leave_r[i]`` ≤ 0: it stays) ignores a
    collision with a neighbour that a candidate would meet only after bringing it within
    that distance: it will have left by then. A contact within the step still counts. Without this, a neighbour standing beyond the goal makes eq. (3) choose
    to creep or stand instead of stepping in (w/tc exceeds the deviation within w metres).

    Keep right (a documented addition to the paper, ``keep_right`` radians, 0 = off): an
    agent that meets an oncoming neighbour — one among its M nearest whose v_pref points
    against its own (cos < −0.5), ahead of it within ``look_s`` seconds of both walking,
    and straight ahead or to its left within the sum of radii plus 0.2 m — turns its own
    v_pref to the right by ``keep_right`` before choosing, so head-on pairs pass left side
    to left side instead of meeting nose to nose.

    Passing those who stand (a documented addition, ``parked``: agents that have arrived and
    stay): a parked neighbour is passed as a standing obstacle, along the ray v′ − v_j (it
    keeps its velocity and takes no share of the avoidance); while one stands in the
    agent's way (ahead along v_pref, its body within ``PASS_SIDE_M`` of the line) the agent
    turns ``PASS_BEYOND_M`` past it, so a wall or parked neighbour met farther along a
    candidate does not count (as past ``aim_dist``), and it squeezes past (walls within
    ``squeeze_s[i]``, below). Eq. (3) otherwise kept a walker behind people standing 1 m
    apart: every straight line through the gaps meets someone or a wall within a few
    metres, and standing costs only ‖v_pref‖. A parked agent ignores a walker whose goal
    is nearer the walker than the parked one's body: it stops short (one walking up to
    its place in front of it made it step aside for nothing). One parked in the way of a
    walker that has stood ``HELD_S`` (``still``, seconds), its goal beyond, steps aside
    square to the walker's line at ``ASIDE_MPS`` until the walker moves on (1.4 m corridor,
    one waiting in its middle: 0.45 m on either side for a 0.5 m body), then goes back.

    Squeezing past (a documented addition, ``squeeze_s[i]`` seconds, inf = off): an agent
    meeting an oncoming neighbour bound the other way (as for keep right, but within the
    sum of radii plus ``squeeze_side`` metres of its line on either side, and the straight
    lines to their ``goals`` over 120° apart) counts a static obstacle's collision only
    when a candidate meets it within ``squeeze_s[i]`` seconds. Eq. (3)
    prices a drift towards a wall 0.2 m off at w · v_perp / 0.2: moving aside to let
    someone pass in a corridor cost more than standing, and two people facing each other
    in a 1.2-1.8 m corridor stood for good. The step's hard constraint (no candidate
    reaching an obstacle within the step) still holds.

    Held up for long (a documented addition, ``held_s[i]`` seconds, inf = off): an agent
    that has stood ``held_s[i]`` seconds (``still``) counts a neighbour's collision only
    when a candidate meets it within ``HELD_HORIZON_S``: a straight ray through the mouth
    of a door, between two standing pressed on its wall faces, meets the one beyond the
    mouth 0.6 m on, and standing priced below it; a 1 m door with 300 people before it
    stood for good. The safety pass still keeps every move of the step apart.
    """
    n = pos.shape[0]
    mcap = 1
    for i in range(n):
        if max_nb[i] > mcap:
            mcap = max_nb[i]
    scap = 0
    for i in range(n):
        scap = max(scap, samples[i])
    n_circ = circ_c.shape[0]
    n_seg = seg_a.shape[0]
    comfort_w = COMFORT_WEIGHT * max(1.0, COMFORT_REF_S / dt)  # per m/s of change beyond the comfortable one
    block = 256
    for blk in prange((n + block - 1) // block):
        # scratch space once per block of agents, not once per agent
        idx = np.empty(mcap, dtype=np.int64)
        d2 = np.empty(mcap, dtype=np.float64)
        rel = np.empty((mcap, 7), dtype=np.float64)
        c_vx = np.empty(scap + 4 + RING, dtype=np.float64)  # the candidates, one array per component
        c_vy = np.empty(scap + 4 + RING, dtype=np.float64)
        c_sp = np.empty(scap + 4 + RING, dtype=np.float64)
        c_dev = np.empty(scap + 4 + RING, dtype=np.float64)
        near_c = np.empty(n_circ, dtype=np.int64)
        near_s = np.empty(n_seg, dtype=np.int64)
        for i in range(blk * block, min(n, (blk + 1) * block)):
            # one agent's choice, written out here: a call per agent passing these ~30
            # arrays cost about 0.6 µs, a fifth of the whole choice in a dense crowd
            if not active[i]:
                out_vel[i, 0] = 0.0
                out_vel[i, 1] = 0.0
                continue
            k = _knn(i, pos, max_nb[i], nb_dist[i], cell_start, items, origin_x, origin_y, h, nx, ny, idx, d2)
            px, py = pos[i, 0], pos[i, 1]
            ri = radius[i]
            vm = vmax[i]
            # obstacles worth testing: within perception D or what the step could reach. A static
            # one farther than ``far`` changes no candidate's choice: a candidate reaches it only
            # after covering that distance, past aim_dist (so its collision does not count, and
            # neither would any obstacle's met later) and past the step (so it stays admissible).
            # The margin covers the rounding of the ray-capsule time.
            far = max(aim_dist[i], vm * dt * (1.0 + SLACK)) * (1.0 + 1e-6) + 1e-6
            nc = 0
            for o in range(n_circ):
                vo = np.sqrt(circ_v[o, 0] * circ_v[o, 0] + circ_v[o, 1] * circ_v[o, 1])
                reach = max(nb_dist[i], 2.0 * (vm + vo) * dt) + ri + circ_r[o]
                dx, dy = px - circ_c[o, 0], py - circ_c[o, 1]
                g2 = dx * dx + dy * dy
                if g2 <= reach * reach:
                    if vo == 0.0 and np.sqrt(g2) - ri - circ_r[o] > far:
                        continue  # standing beyond what any candidate counts (see far)
                    near_c[nc] = o
                    nc += 1
            ns = 0
            for o in range(n_seg):
                vo = np.sqrt(seg_v[o, 0] * seg_v[o, 0] + seg_v[o, 1] * seg_v[o, 1])
                reach = max(nb_dist[i], 2.0 * (vm + vo) * dt) + ri
                gap = _point_segment_distance(px, py, seg_a[o, 0], seg_a[o, 1], seg_b[o, 0], seg_b[o, 1])
                if gap <= reach:
                    if vo == 0.0 and gap - ri > far:
                        continue  # standing beyond what any candidate counts (see far)
                    near_s[ns] = o
                    ns += 1
            best_pen = INF
            best_any = INF
            bx, by = 0.0, 0.0
            ax_, ay_ = 0.0, 0.0
            vix, viy = vel[i, 0], vel[i, 1]
            wx, wy = _kept_right(i, k, idx, pos, vpref, radius, vpref[i, 0], vpref[i, 1], keep_right, look_s)
            if parked[i]:  # one standing in a held walker's way steps aside for it
                wx, wy = _aside(i, k, idx, pos, vpref, radius, parked, still, goals, wx, wy)
            wall_s = INF  # a static obstacle's collision counts when met within this many seconds
            # (only obstacles within reach can be squeezed past: in the open the test is skipped)
            if squeeze_s[i] < INF and nc + ns > 0 and _meets_oncoming(
                    i, k, idx, pos, vpref, radius, vpref[i, 0], vpref[i, 1], look_s, 1.0, squeeze_side,
                    squeeze_side, goals):
                wall_s = squeeze_s[i]  # squeezing past one coming towards us
            w_i = safety[i]
            held_i = still[i] >= held_s[i]
            # within reach of leaving on arrival (LEAVE_LOOK_S at most at vm, every candidate's top
            # speed): farther off, no candidate counts on leaving
            gx_, gy_ = px - goals[i, 0], py - goals[i, 1]
            may_leave = leave_r[i] > 0.0 and gx_ * gx_ + gy_ * gy_ <= (leave_r[i] + vm * LEAVE_LOOK_S) ** 2
            # per-neighbour constants of the ray p_i + (a v' + c) t: reciprocal, a = 2 and
            # c = -v_i - v_j; or, for a neighbour we follow (ahead of us, bound our way), a = 1 and
            # c = -(its velocity anticipated ``follow[i]`` of the way to its v_pref): it will not
            # make room for us, and we expect it to walk on
            un = np.sqrt(wx * wx + wy * wy)
            aim_i = aim_dist[i]  # how far ahead the agent turns: its aim, or past a parked one in its way
            for q in range(k):
                j = idx[q]
                rel[q, 0] = px - pos[j, 0]
                rel[q, 1] = py - pos[j, 1]
                rr_ = ri + radius[j]
                rel[q, 2] = rel[q, 0] * rel[q, 0] + rel[q, 1] * rel[q, 1] - rr_ * rr_
                rel[q, 3] = -vix - vel[j, 0]
                rel[q, 4] = -viy - vel[j, 1]
                rel[q, 5] = 2.0
                rel[q, 6] = 0.0
                if parked[j]:
                    # parked (waiting, or arrived and staying): it keeps its velocity and takes
                    # no share of the avoidance; it counts as a static thing
                    rel[q, 3] = -vel[j, 0]
                    rel[q, 4] = -vel[j, 1]
                    rel[q, 5] = 1.0
                    rel[q, 6] = 1.0
                    if un > 0.0:  # in our way: we turn once past it, and what lies beyond does not count yet
                        ahead = -(rel[q, 0] * wx + rel[q, 1] * wy) / un
                        if ahead > 0.0 and abs(rel[q, 0] * wy - rel[q, 1] * wx) / un < rr_ + PASS_SIDE_M:
                            aim_i = min(aim_i, ahead + PASS_BEYOND_M)
                            wall_s = min(wall_s, squeeze_s[i])  # and squeezes past it, as past one oncoming
                elif parked[i]:
                    # we stand and it walks: one whose goal is nearer it than we are stops short of us
                    gjx, gjy = goals[j, 0] - pos[j, 0], goals[j, 1] - pos[j, 1]
                    reach = np.sqrt(rel[q, 0] * rel[q, 0] + rel[q, 1] * rel[q, 1]) - rr_
                    if reach > 0.0 and gjx * gjx + gjy * gjy < reach * reach:
                        rel[q, 6] = 2.0
                elif follow[i] > 0.0 and un > 0.0:
                    pjx, pjy = vpref[j, 0], vpref[j, 1]
                    side = abs(rel[q, 0] * wy - rel[q, 1] * wx) / un  # |lateral offset| from our line
                    ahead = -(rel[q, 0] * wx + rel[q, 1] * wy) / un   # how far ahead of us along it
                    # (the square root only for one in our line ahead: most neighbours are not)
                    pn = np.sqrt(pjx * pjx + pjy * pjy) if ahead >= rr_ and side < rr_ else 0.0
                    if pn > 0.0 and pjx * wx + pjy * wy > 0.9 * pn * un:
                        # anticipate only as far as it is under way already: one standing in a
                        # jam is expected to stand
                        free = min(max((vel[j, 0] * pjx + vel[j, 1] * pjy) / (pn * pn), 0.0), 1.0)
                        rel[q, 3] = -(vel[j, 0] + follow[i] * free * (pjx - vel[j, 0]))
                        rel[q, 4] = -(vel[j, 1] + follow[i] * free * (pjy - vel[j, 1]))
                        rel[q, 5] = 1.0
            # random samples: a sunflower pattern of N_sample points filling the disc of radius
            # v_max, turned by a random angle and shifted by a random radial offset each step, so
            # every sample is uniform on the disc and together they cover it evenly
            n_s = samples[i]
            offset = _uniform(key, i, 0)
            phi = 2.0 * np.pi * _uniform(key, i, 1)
            ca, sa = np.cos(phi), np.sin(phi)
            reach_i = comfort[i]  # the change of velocity this step can make comfortably (0: no limit)
            ex, ey = wx - vix, wy - viy
            en = np.sqrt(ex * ex + ey * ey)
            gx, gy = wx, wy  # v_pref, or as near it as a comfortable change gets
            if reach_i > 0.0 and en > reach_i:
                gx, gy = vix + ex * reach_i / en, viy + ey * reach_i / en
            n_ring = RING if reach_i > 0.0 else 0
            # the candidates are built first, their square roots in loops without branches that
            # the compiler vectorises (built one at a time inside the loop that weighs them, the
            # choice took 15-20 % longer), then weighed one at a time in the same order
            n_c = n_s + 4 + n_ring
            for cnd in range(4 + n_ring):
                if cnd == 0:
                    cx_, cy_ = wx, wy
                elif cnd == 1:
                    cx_, cy_ = vix, viy
                elif cnd == 2:
                    cx_, cy_ = 0.0, 0.0
                elif cnd == 3:
                    cx_, cy_ = gx, gy
                else:  # the comfortable changes all round the current velocity
                    ang = phi + 2.0 * np.pi * (cnd - 4) / n_ring
                    cx_, cy_ = vix + reach_i * np.cos(ang), viy + reach_i * np.sin(ang)
                c_vx[cnd] = cx_
                c_vy[cnd] = cy_
            for cnd in range(4 + n_ring, n_c):  # the sunflower's turns, each from the last
                c_vx[cnd] = ca
                c_vy[cnd] = sa
                ca, sa = ca * GOLDEN_COS - sa * GOLDEN_SIN, sa * GOLDEN_COS + ca * GOLDEN_SIN
            for cnd in range(4 + n_ring, n_c):  # the sunflower's radii (no branches: vectorised)
                rr = vm * np.sqrt((cnd - 4 - n_ring + offset) / n_s)
                c_vx[cnd] = rr * c_vx[cnd]
                c_vy[cnd] = rr * c_vy[cnd]
            for cnd in range(n_c):  # speed (at most vm) and deviation, no branches
                cx_, cy_ = c_vx[cnd], c_vy[cnd]
                sp = np.sqrt(cx_ * cx_ + cy_ * cy_)
                over = sp > vm  # the current velocity or v_pref may exceed a lowered max speed
                cx_ = cx_ * (vm / sp) if over else cx_
                cy_ = cy_ * (vm / sp) if over else cy_
                sp = vm if over else sp
                dvx, dvy = wx - cx_, wy - cy_
                dev = np.sqrt(dvx * dvx + dvy * dvy)
                # a harder change than comfortable costs comfort_w per m/s beyond
                chx, chy = cx_ - vix, cy_ - viy
                extra = comfort_w * max(np.sqrt(chx * chx + chy * chy) - reach_i, 0.0)
                c_vx[cnd] = cx_
                c_vy[cnd] = cy_
                c_sp[cnd] = sp
                c_dev[cnd] = dev + extra if reach_i > 0.0 else dev
            for cnd in range(n_c):
                dev = c_dev[cnd]
                if dev >= best_pen:
                    continue  # its penalty cannot beat the best admissible candidate
                cx_, cy_ = c_vx[cnd], c_vy[cnd]
                # neighbours first: their time to collision alone bounds the penalty from
                # below, so a candidate they already rule out needs no obstacle tests
                limit = -1.0 if best_pen == INF else w_i / max(best_pen - dev, 1e-300)
                gone = INF  # when the candidate brings the agent within leave_r of its goal: it leaves
                if may_leave:
                    gone = _ray_disc(gx_, gy_, cx_, cy_, leave_r[i])
                    if gone < dt:
                        gone = dt  # it leaves at the end of the step
                    elif gone > LEAVE_LOOK_S:
                        gone = INF  # too far off to count on
                tc = INF
                for q in range(k):
                    vrx = rel[q, 5] * cx_ + rel[q, 3]
                    vry = rel[q, 5] * cy_ + rel[q, 4]
                    b = rel[q, 0] * vrx + rel[q, 1] * vry
                    c0 = rel[q, 2]
                    if c0 < 0.0:
                        tc = 0.0
                        break  # (overlapping a parked one counts in full too)
                    if b >= 0.0:
                        continue
                    a = vrx * vrx + vry * vry
                    disc = b * b - a * c0
                    if disc <= 0.0:
                        continue
                    tt = (-b - np.sqrt(disc)) / a
                    if tt >= gone:
                        continue  # it will have left before that collision
                    if rel[q, 6] == 1.0 and tt * c_sp[cnd] > aim_i:
                        continue  # a parked one met only past where we turn (as a wall there)
                    if rel[q, 6] == 2.0:
                        continue  # a walker that stops short of us
                    if held_i and tt > HELD_HORIZON_S:
                        continue  # standing held up for long: only what it meets soon counts
                    if tt < tc:
                        tc = tt
                        if tc < limit:
                            break  # already worse than the best: w/tc + dev >= best
                if tc < limit:
                    continue  # w/tc + dev > best, whatever the obstacles add
                sp = c_sp[cnd]
                t_static, t_moving = INF, INF
                if nc + ns > 0:
                    t_static, t_moving = _obstacle_time(px, py, cx_, cy_, ri, circ_c, circ_r, circ_v, near_c, nc,
                                                        seg_a, seg_b, seg_v, near_s, ns)
                t_obs = min(t_static if t_static <= wall_s else INF, t_moving)
                if t_obs < INF and not (sp > 0.0 and t_obs * sp > aim_i):
                    tc = min(tc, t_obs)
                if tc == INF:
                    pen = dev
                elif tc <= 1e-12:
                    pen = w_i * 1e12 + dev
                else:
                    pen = w_i / tc + dev  # eq. (3)
                if t_static >= dt * (1.0 + SLACK):
                    if t_moving >= dt * (1.0 + SLACK) and pen < best_pen:
                        best_pen, bx, by = pen, cx_, cy_
                    if pen < best_any:
                        best_any, ax_, ay_ = pen, cx_, cy_
            if best_pen < INF:
                out_vel[i, 0], out_vel[i, 1] = bx, by
                out_forced[i] = False
            else:
                out_vel[i, 0], out_vel[i, 1] = ax_, ay_
                out_forced[i] = True


@njit(inline="always")
def _aside(i, k, idx, pos, vpref, radius, parked, still, goals, wx, wy):
    """A parked agent's v_pref: ``(wx, wy)``, or a step aside at ASIDE_MPS when a walker
    among its ``k`` neighbours ``idx`` has stood HELD_S (``still``, seconds)
    within ASIDE_AHEAD_M of it with it in its way (its body within the sum of radii of the
    walker's line, the walker's goal beyond it): square to that line, away from it (to the
    walker's right when on it)."""
    for q in range(k):
        j = idx[q]
        if parked[j]:
            continue
        ojx, ojy = vpref[j, 0], vpref[j, 1]
        on = np.sqrt(ojx * ojx + ojy * ojy)
        if on == 0.0 or still[j] < HELD_S:
            continue
        ux, uy = ojx / on, ojy / on
        dx, dy = pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1]
        ahead = dx * ux + dy * uy
        lat = dx * uy - dy * ux  # + = to the walker's right
        if ahead <= 0.0 or ahead > ASIDE_AHEAD_M + radius[i] + radius[j] or abs(lat) >= radius[i] + radius[j]:
            continue
        gx, gy = goals[j, 0] - pos[j, 0], goals[j, 1] - pos[j, 1]
        if gx * gx + gy * gy <= ahead * ahead:
            continue  # it stops short of us
        side = 1.0 if lat >= -1e-6 else -1.0
        return side * uy * ASIDE_MPS, -side * ux * ASIDE_MPS
    return wx, wy


@njit(inline="always")
def _kept_right(i, k, idx, pos, vpref, radius, wx, wy, keep_right, look_s):
    """v_pref turned right by ``keep_right`` if an oncoming neighbour is ahead (see
    :func:`choose_velocities`), else unchanged."""
    if keep_right <= 0.0 or not _meets_oncoming(i, k, idx, pos, vpref, radius, wx, wy, look_s, 0.25, 0.0, 0.2,
                                                 None):
        return wx, wy
    c, s = np.cos(keep_right), np.sin(keep_right)
    return wx * c + wy * s, -wx * s + wy * c


@njit(inline="always")
def _meets_oncoming(i, k, idx, pos, vpref, radius, wx, wy, look_s, right_bodies, right_m, left_m, goals):
    """Whether one of agent i's ``k`` neighbours ``idx`` comes towards it (v_pref against
    ``(wx, wy)``, cos < −0.5), ahead within ``look_s`` seconds of both walking, and across
    our line from ``right_bodies`` × the sum of radii + ``right_m`` metres on our right to
    the sum of radii + ``left_m`` on our left; with ``goals`` (not None), only one bound
    the other way (the straight lines to their goals over 120° apart): two converging on
    one door from either side come towards each other too, but bound the same way."""
    wn = np.sqrt(wx * wx + wy * wy)
    if wn == 0.0:
        return False
    ux, uy = wx / wn, wy / wn
    for q in range(k):
        j = idx[q]
        ojx, ojy = vpref[j, 0], vpref[j, 1]
        on = np.sqrt(ojx * ojx + ojy * ojy)
        if on == 0.0 or ojx * ux + ojy * uy >= -0.5 * on:
            continue  # standing, or not coming towards us
        dx, dy = pos[j, 0] - pos[i, 0], pos[j, 1] - pos[i, 1]
        ahead = dx * ux + dy * uy
        if ahead <= 0.0 or ahead > look_s * (wn + on):
            continue
        lateral = ux * dy - uy * dx  # > 0: on our left
        reach = radius[i] + radius[j]
        if not -right_bodies * reach - right_m <= lateral <= reach + left_m:
            continue
        if goals is not None:
            gix, giy = goals[i, 0] - pos[i, 0], goals[i, 1] - pos[i, 1]
            gjx, gjy = goals[j, 0] - pos[j, 0], goals[j, 1] - pos[j, 1]
            if not gix * gjx + giy * gjy < -0.5 * np.sqrt((gix * gix + giy * giy) * (gjx * gjx + gjy * gjy)):
                continue
        return True
    return False


# ---- guidance: the distance field (line of sight lives in crowdmotion._contact) --------------
@threaded
def field_directions(pos, field_of, dist, origin_x, origin_y, cell, window, use, radius,
                     circ_c, circ_r, seg_a, seg_b, inside, out):
    """Offset to the next aim point along an exact distance field, for agents with ``use``.

    ``dist`` is (F, nx, ny) metres to the nearest goal cell (inf where blocked). The agent
    aims at the window cell c (within ``window`` cells) minimising dist[c] + ‖centre(c) − p‖
    among the cells it can walk to in a straight line: a look-ahead on the shortest path
    that turns the field's 8 directions into smooth headings without cutting corners.
    A cell whose centre no body of the agent's radius stands on (a narrow passage's,
    opened by ``routing.narrow_passages`` where a body fits at some point of it) is aimed
    at the first of the points ``inside`` ((K, 2) offsets from its centre, nearest first)
    that the agent can walk to: aiming at the centres alone, a walker at the mouth of a
    1.2 m door (radius 0.5 m, 0.5 m cells) saw none of the door's cells and paced on the
    spot before it for good.
    """
    n = pos.shape[0]
    gx_n, gy_n = dist.shape[1], dist.shape[2]
    for i in prange(n):
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        if not use[i]:
            continue
        f = field_of[i]
        px, py = pos[i, 0], pos[i, 1]
        cx = int(np.floor((px - origin_x) / cell))
        cy = int(np.floor((py - origin_y) / cell))
        # the window's cells by cost; the cheapest one in sight wins (of equal costs, the
        # first in the window's order): line of sight is tested cheapest first, until one is clear
        cost = np.empty((2 * window + 1) * (2 * window + 1))
        offx = np.empty_like(cost)
        offy = np.empty_like(cost)
        m = 0
        for gx in range(max(cx - window, 0), min(cx + window, gx_n - 1) + 1):
            for gy in range(max(cy - window, 0), min(cy + window, gy_n - 1) + 1):
                d = dist[f, gx, gy]
                if d == INF:
                    continue
                ex = origin_x + (gx + 0.5) * cell - px
                ey = origin_y + (gy + 0.5) * cell - py
                cost[m] = d + np.sqrt(ex * ex + ey * ey)
                offx[m], offy[m] = ex, ey
                m += 1
        while True:
            best = INF
            b = -1
            for q in range(m):
                if cost[q] < best:
                    best, b = cost[q], q
            if b < 0:
                break
            qx, qy = px + offx[b], py + offy[b]
            if _clear(px, py, qx, qy, radius[i], circ_c, circ_r, seg_a, seg_b):
                out[i, 0] = offx[b]
                out[i, 1] = offy[b]
                break
            if not _clear(qx, qy, qx, qy, radius[i], circ_c, circ_r, seg_a, seg_b):
                found = False
                for k in range(inside.shape[0]):  # no body stands on its centre: a point of it
                    if _clear(px, py, qx + inside[k, 0], qy + inside[k, 1], radius[i], circ_c, circ_r, seg_a,
                              seg_b):
                        out[i, 0] = offx[b] + inside[k, 0]
                        out[i, 1] = offy[b] + inside[k, 1]
                        found = True
                        break
                if found:
                    break
            cost[b] = INF


@njit(cache=True)
def held_up_time(wanted, chosen, pref_speed, active, yield_to, slow, dt, stuck):
    """Seconds each agent has been held up, in place (``rvo.deadlock``): + dt for a step
    walked slower than ``slow`` x its preferred speed along a v_pref of at least a fifth
    of it, - dt (not below 0) for any other step: leaky, so inching forward now and then
    does not wipe out the wait. Zero for agents gone or yielding."""
    for i in range(stuck.shape[0]):
        if not active[i] or yield_to[i] >= 0:
            stuck[i] = 0.0
            continue
        wx, wy = wanted[i, 0], wanted[i, 1]
        speed = np.sqrt(wx * wx + wy * wy)
        along = (chosen[i, 0] * wx + chosen[i, 1] * wy) / speed if speed > 0.0 else 0.0
        if speed > 0.2 * pref_speed[i] and along < slow * pref_speed[i]:
            stuck[i] += dt
        else:
            stuck[i] = max(stuck[i] - dt, 0.0)


# ---- density ahead (rvo.density) ----------------------------------------------------------------
@njit(inline="always")
def _cell_box(cx, cy, reach, origin_x, origin_y, h, nx, ny):
    """(gx0, gx1, gy0, gy1): the grid cells, clamped to the grid, that hold every point
    within ``reach`` of (cx, cy); an empty range when the square lies off the grid."""
    gx0 = max(int(np.floor((cx - reach - origin_x) / h)), 0)
    gx1 = min(int(np.floor((cx + reach - origin_x) / h)), nx - 1)
    gy0 = max(int(np.floor((cy - reach - origin_y) / h)), 0)
    gy1 = min(int(np.floor((cy + reach - origin_y) / h)), ny - 1)
    return gx0, gx1, gy0, gy1


@njit(cache=True)
def _items_in_box(cell_start, ny, gx0, gx1, gy0, gy1):
    """How many agents the grid cells gx0 … gx1 × gy0 … gy1 hold (none for an empty range):
    for one gx the cells gy0 … gy1 hold consecutive items."""
    bound = 0
    if gy1 >= gy0:
        for gx in range(gx0, gx1 + 1):
            bound += cell_start[gx * ny + gy1 + 1] - cell_start[gx * ny + gy0]
    return bound


@threaded
def density_ahead(centre, own, pos, vel, head, oncoming_speed, wanted, goals, cell_start, items, origin_x, origin_y,
                  h, nx, ny, sigma, out, out_with, out_against):
    """Gaussian-weighted count of the agents in the grid round each point ``centre[k]``:
    Σ_j exp(−|p_j − c_k|² / 2σ²) over the agents within 3σ of it but agent ``own[k]``, the
    one sensing, into ``out``; into ``out_with`` the same count with each agent weighted by
    how far it goes our way: 1 when standing or going along ``head[k]``, falling linearly
    to 0 as it comes towards us at ``oncoming_speed``; into ``out_against`` the count of
    those bound the other way or across our way: wanting to go over 60° off ``head[k]``
    (``wanted``), with the straight lines to their goals and ours over 120° apart, or over
    60° apart and their goal farther from ours than we are (two converging on one door
    from either side face each other, but are bound to one place). Divided by the
    kernel's area (:mod:`crowdmotion.rvo.density`) it is the density there, persons/m²."""
    n = centre.shape[0]
    reach = 3.0 * sigma
    r2 = reach * reach
    inv = 1.0 / (2.0 * sigma * sigma)
    block = 64
    for blk in prange((n + block - 1) // block):
        # scratch once per block of points (grown when a box holds more), not once per point
        b_j = np.empty(64, dtype=np.int64)
        b_d2 = np.empty(64)
        for k in range(blk * block, min(n, (blk + 1) * block)):
            cx, cy = centre[k, 0], centre[k, 1]
            hx, hy = head[k, 0], head[k, 1]
            i = own[k]
            gix, giy = goals[i, 0] - pos[i, 0], goals[i, 1] - pos[i, 1]
            gin = np.sqrt(gix * gix + giy * giy)
            gx0, gx1, gy0, gy1 = _cell_box(cx, cy, reach, origin_x, origin_y, h, nx, ny)
            s = 0.0
            sw = 0.0
            sa = 0.0
            # the agents within reach, gathered without branches (for one gx the cells gy0 … gy1
            # hold consecutive items), then summed in the cells' order
            bound = _items_in_box(cell_start, ny, gx0, gx1, gy0, gy1)
            if bound > len(b_j):
                b_j = np.empty(2 * bound, dtype=np.int64)
                b_d2 = np.empty(2 * bound)
            cnt = 0
            for gx in range(gx0, gx1 + 1 if gy1 >= gy0 else gx0):
                for q in range(cell_start[gx * ny + gy0], cell_start[gx * ny + gy1 + 1]):
                    j = items[q]
                    dx = pos[j, 0] - cx
                    dy = pos[j, 1] - cy
                    d2 = dx * dx + dy * dy
                    b_j[cnt] = j
                    b_d2[cnt] = d2
                    cnt += (j != own[k]) & (d2 < r2)
            for q in range(cnt):
                j = b_j[q]
                g = np.exp(-b_d2[q] * inv)
                s += g
                along = vel[j, 0] * hx + vel[j, 1] * hy
                w = 1.0 + along / oncoming_speed if along < 0.0 else 1.0
                if w > 0.0:
                    sw += g * w
                wjx, wjy = wanted[j, 0], wanted[j, 1]
                if wjx * hx + wjy * hy < CROSSING_COS * np.sqrt(wjx * wjx + wjy * wjy):
                    gjx, gjy = goals[j, 0] - pos[j, 0], goals[j, 1] - pos[j, 1]
                    gc = gix * gjx + giy * gjy  # the straight lines to the two goals ...
                    gn = gin * np.sqrt(gjx * gjx + gjy * gjy)
                    if gc < AGAINST_COS * gn:
                        sa += g  # ... over 120° apart: bound the other way
                    elif gc < CROSSING_COS * gn:
                        # crossing our way: bound elsewhere if its goal lies farther from ours
                        # than we are (two converging on one door from beside are bound to one place)
                        dgx, dgy = goals[j, 0] - goals[i, 0], goals[j, 1] - goals[i, 1]
                        if dgx * dgx + dgy * dgy > gin * gin:
                            sa += g
            out[k] = s
            out_with[k] = sw
            out_against[k] = sa


# ---- escape from moving obstacles after the safety pass ----------------------------------------
@njit(cache=True)
def escape_moving_obstacles(pos, vel, vpref, radius, vmax, threatened, cell_start, items, origin_x, origin_y, h,
                            nx, ny, circ_c, circ_r, circ_v, seg_a, seg_b, seg_v, dt, n_dirs):
    """Agents whose final move (after the safety pass) would let a moving obstacle reach them
    within the step take instead the velocity nearest their v_pref, among ``n_dirs``
    headings at a third, two thirds and all of v_max, that keeps out of every obstacle for
    the step and touches no other agent's final move (nobody is assumed to make room);
    none such: they keep their move. Agents are settled one after another, so the
    step stays free of contacts. ``threatened`` marks the agents worth checking; returns
    how many changed their move."""
    n = pos.shape[0]
    n_circ = circ_c.shape[0]
    n_seg = seg_a.shape[0]
    near_c = np.empty(n_circ, dtype=np.int64)
    near_s = np.empty(n_seg, dtype=np.int64)
    for o in range(n_circ):
        near_c[o] = o
    for o in range(n_seg):
        near_s[o] = o
    firm = np.empty(n, dtype=np.bool_)
    for i in range(n):
        firm[i] = True
    buf = np.empty(9 * max_cell(cell_start) + 1, dtype=np.int64)
    changed = 0
    for i in range(n):
        if not threatened[i]:
            continue
        px, py = pos[i, 0], pos[i, 1]
        ri = radius[i]
        vx0, vy0 = vel[i, 0], vel[i, 1]
        _, t_moving = _obstacle_time(px, py, vx0, vy0, ri, circ_c, circ_r, circ_v, near_c, n_circ,
                                     seg_a, seg_b, seg_v, near_s, n_seg)
        if t_moving >= dt * (1.0 + SLACK):
            continue
        best = INF
        bx, by = vx0, vy0
        for level in range(1, 4):
            sp = vmax[i] * level / 3.0
            for d in range(n_dirs):
                ang = 2.0 * np.pi * d / n_dirs
                cx_, cy_ = sp * np.cos(ang), sp * np.sin(ang)
                dx, dy = vpref[i, 0] - cx_, vpref[i, 1] - cy_
                dev = np.sqrt(dx * dx + dy * dy)
                if dev >= best:
                    continue
                t_s, t_m = _obstacle_time(px, py, cx_, cy_, ri, circ_c, circ_r, circ_v, near_c, n_circ,
                                          seg_a, seg_b, seg_v, near_s, n_seg)
                if t_s < dt * (1.0 + SLACK) or t_m < dt * (1.0 + SLACK):
                    continue
                vel[i, 0], vel[i, 1] = cx_, cy_
                if not _conflict(i, pos, vel, radius, firm, radius, cell_start, items, origin_x, origin_y, h, nx,
                                 ny, dt, buf):
                    best, bx, by = dev, cx_, cy_
        vel[i, 0], vel[i, 1] = bx, by
        if best < INF:
            changed += 1
    return changed


# ---- lane choice in counterflow (rvo.lanes) ------------------------------------------------------
@threaded(min_items=PARALLEL_MIN_AGENTS)
def lane_choice(pos, vel, vpref, radius, weight, active, cell_start, items, origin_x, origin_y, h, nx, ny,
                circ_c, circ_r, seg_a, seg_b, look, spread, offsets, aim, side_cost, right_bonus, min_pressure,
                crowd_weight, out):
    """v_pref turned towards the lateral offset with the least oncoming traffic ahead.

    For agent i walking along û (its v_pref), the oncoming agents j (v_pref against û,
    cos < −0.5) that lie 0–``look`` metres ahead weigh exp(−ahead / (look / 2)), spread
    over the lateral offset as a Gaussian of width ``spread`` round their own. Among the
    ``offsets`` (metres, + = right) whose aim point p + aim·û + offset·n̂ (n̂ the right
    normal) the body can walk to in a straight line, the agent takes the one minimising
    pressure + side_cost·|offset| − right_bonus·offset and heads for its aim point at the
    same speed. The pressure is scaled by the agent's own ``weight``. An agent going our
    way (not oncoming) weighs ``crowd_weight`` times the share of our preferred speed by
    which it is slower (current velocity along û): a crowd ahead that stands weighs fully,
    one walking at our pace not at all. Below ``min_pressure`` at offset 0 (nobody in the
    way) v_pref is kept."""
    n = pos.shape[0]
    n_off = offsets.shape[0]
    inv2 = 1.0 / (2.0 * spread * spread)
    # offsets on a lattice (multiples m_k of one step, the usual case): a neighbour at
    # lateral lat weighs exp(−(lat − m·step)²/2σ²) = exp(−lat²/2σ²) · E^m · exp(−(m·step)²/2σ²)
    # with E = exp(lat·step/σ²): two exp per neighbour instead of one per offset, the last
    # factor once per agent. Off the lattice: one exp per offset.
    step = INF
    widest = 0.0
    for k in range(n_off):
        if offsets[k] != 0.0:
            step = min(step, abs(offsets[k]))
        widest = max(widest, abs(offsets[k]))
    mult = np.zeros(n_off, dtype=np.int64)
    lattice = step < INF and widest <= 12.0 * spread and widest <= 64.0 * step
    if lattice:
        for k in range(n_off):
            mult[k] = int(np.round(offsets[k] / step))
            if abs(offsets[k] - mult[k] * step) > 1e-9 * step:
                lattice = False
    m_max = 0
    for k in range(n_off):
        m_max = max(m_max, abs(mult[k]))
    # a neighbour farther aside than this from every offset adds under exp(−TRUNCATE) of
    # its weight to any: left out
    lat_max = widest + np.sqrt(LANE_TRUNCATE / inv2)
    block = 64
    for blk in prange((n + block - 1) // block):
        # scratch once per block of agents (the strip's grown when a strip holds more)
        pres = np.empty(n_off)
        acc = np.empty(2 * m_max + 1)  # Σ_j weight_j exp(−lat_j²/2σ²) E_j^m, m = −m_max … m_max
        b_j = np.empty(256, dtype=np.int64)
        b_ahead = np.empty(256)
        b_lat = np.empty(256)
        for i in range(blk * block, min(n, (blk + 1) * block)):
            out[i, 0] = vpref[i, 0]
            out[i, 1] = vpref[i, 1]
            if not active[i] or weight[i] == 0.0:  # no pressure anywhere: v_pref as it is
                continue
            wx, wy = vpref[i, 0], vpref[i, 1]
            sp = np.sqrt(wx * wx + wy * wy)
            if sp == 0.0:
                continue
            ux, uy = wx / sp, wy / sp
            rx, ry = uy, -ux  # right normal
            px, py = pos[i, 0], pos[i, 1]
            # the cells of the box round the strip 0 < ahead <= look, |lateral| <= lat_max
            x0 = px + min(0.0, look * ux) - lat_max * abs(rx)
            x1 = px + max(0.0, look * ux) + lat_max * abs(rx)
            y0 = py + min(0.0, look * uy) - lat_max * abs(ry)
            y1 = py + max(0.0, look * uy) + lat_max * abs(ry)
            gx0 = max(int(np.floor((x0 - origin_x) / h)), 0)
            gx1 = min(int(np.floor((x1 - origin_x) / h)), nx - 1)
            gy0 = max(int(np.floor((y0 - origin_y) / h)), 0)
            gy1 = min(int(np.floor((y1 - origin_y) / h)), ny - 1)
            pres[:] = 0.0
            acc[:] = 0.0
            # the agents in the strip, gathered without branches (which way the tests go is
            # random from one agent to the next), in the cells' order (for one gx the cells
            # gy0 … gy1 hold consecutive items)
            bound = _items_in_box(cell_start, ny, gx0, gx1, gy0, gy1)
            if bound > len(b_j):
                b_j = np.empty(2 * bound, dtype=np.int64)
                b_ahead = np.empty(2 * bound)
                b_lat = np.empty(2 * bound)
            cnt = 0
            for gx in range(gx0, gx1 + 1 if gy1 >= gy0 else gx0):
                for q in range(cell_start[gx * ny + gy0], cell_start[gx * ny + gy1 + 1]):
                    j = items[q]
                    dx, dy = pos[j, 0] - px, pos[j, 1] - py
                    ahead = dx * ux + dy * uy
                    lat = dx * rx + dy * ry
                    b_j[cnt] = j
                    b_ahead[cnt] = ahead
                    b_lat[cnt] = lat
                    cnt += (j != i) & (ahead > 0.0) & (ahead <= look) & (abs(lat) <= lat_max)
            for r in range(cnt):
                j = b_j[r]
                ahead = b_ahead[r]
                lat = b_lat[r]
                ojx, ojy = vpref[j, 0], vpref[j, 1]
                share = 1.0
                if not ojx * ux + ojy * uy < -0.5 * np.sqrt(ojx * ojx + ojy * ojy):
                    # one going our way is in the way as far as it is slower
                    lag = 1.0 - (vel[j, 0] * ux + vel[j, 1] * uy) / sp
                    share = crowd_weight * min(max(lag, 0.0), 1.0)
                    if share == 0.0:
                        continue
                if lattice:
                    a = share * np.exp(-2.0 * ahead / look - lat * lat * inv2)
                    e = np.exp(2.0 * lat * step * inv2)
                    acc[m_max] += a
                    up = a
                    down = a
                    einv = 1.0 / e
                    for m in range(1, m_max + 1):  # both chains of powers in one loop: they overlap
                        up *= e
                        down *= einv
                        acc[m_max + m] += up
                        acc[m_max - m] += down
                else:
                    wgt = share * np.exp(-2.0 * ahead / look)
                    for k in range(n_off):
                        d = lat - offsets[k]
                        pres[k] += wgt * np.exp(-d * d * inv2)
            if lattice:
                for k in range(n_off):
                    y = mult[k] * step
                    pres[k] = acc[m_max + mult[k]] * np.exp(-y * y * inv2)
            for k in range(n_off):
                pres[k] *= weight[i]
            if not pres[0] >= min_pressure:  # offsets[0] is 0: nobody in the way straight on
                continue
            # the clear offset of least cost (the first on a tie): offsets tried cheapest first
            for k in range(n_off):
                y = offsets[k]
                pres[k] = pres[k] + side_cost * abs(y) - right_bonus * y
            best_off = 0.0
            while True:
                best_cost = INF
                kb = -1
                for k in range(n_off):
                    if pres[k] < best_cost:
                        best_cost = pres[k]
                        kb = k
                if kb < 0:
                    break
                y = offsets[kb]
                if y == 0.0 or _clear(px, py, px + aim * ux + y * rx, py + aim * uy + y * ry, radius[i],
                                      circ_c, circ_r, seg_a, seg_b):
                    best_off = y
                    break
                pres[kb] = INF
            if best_off == 0.0:
                continue
            dx, dy = aim * ux + best_off * rx, aim * uy + best_off * ry
            dn = np.sqrt(dx * dx + dy * dy)
            out[i, 0] = sp * dx / dn
            out[i, 1] = sp * dy / dn


# ---- the per-agent bookkeeping round the terms (rvo.density, rvo.lanes) ---------------------------
# Each is a few arithmetic operations an agent; as numpy expressions over (N, 2) arrays
# (divisions with ``where``, boolean indexing) they cost 2-3 ms a step at 10,000 agents.
@njit(cache=True)
def points_ahead(pos, heading, own, ahead, centre, head):
    """For each agent ``own[k]``: ``head[k]`` its unit ``heading`` (0 if it has none) and
    ``centre[k]`` the point ``ahead`` metres in front of it along that."""
    for k in range(own.shape[0]):
        i = own[k]
        hx, hy = heading[i, 0], heading[i, 1]
        hn = np.sqrt(hx * hx + hy * hy)
        ux, uy = (hx / hn, hy / hn) if hn > 0.0 else (0.0, 0.0)
        head[k, 0], head[k, 1] = ux, uy
        centre[k, 0] = pos[i, 0] + ahead * ux
        centre[k, 1] = pos[i, 1] + ahead * uy


@njit(cache=True)
def raster_at(share, origin_x, origin_y, cell, points, out):
    """``out[k]``: the raster value of the cell holding ``points[k]`` (0 outside it)."""
    sx, sy = share.shape
    for k in range(points.shape[0]):
        fx = np.floor((points[k, 0] - origin_x) / cell)
        fy = np.floor((points[k, 1] - origin_y) / cell)
        out[k] = share[int(fx), int(fy)] if 0.0 <= fx < sx and 0.0 <= fy < sy else 0.0


@njit(cache=True)
def lanes_due(vpref, heading, pos, goals, active, steps, period, cos_rethink, near_m, due):
    """``due[i]``: active agent i chooses its lane this step: its turn ((i + ``steps``) a
    multiple of ``period``), its v_pref turned from ``heading[i]`` (the unit v_pref of its
    last choice) to a cosine below ``cos_rethink``, or its goal within ``near_m``."""
    for i in range(vpref.shape[0]):
        if not active[i]:
            due[i] = False
            continue
        vx, vy = vpref[i, 0], vpref[i, 1]
        sp = np.sqrt(vx * vx + vy * vy)
        ux, uy = (vx / sp, vy / sp) if sp > 0.0 else (0.0, 0.0)
        gx, gy = goals[i, 0] - pos[i, 0], goals[i, 1] - pos[i, 1]
        due[i] = ((ux * heading[i, 0] + uy * heading[i, 1] < cos_rethink) or gx * gx + gy * gy < near_m * near_m
                  or (i + steps) % period == 0)


@njit(cache=True)
def lanes_keep(vpref, out, due, active, turn, heading):
    """After the lane choice of the ``due`` agents (``out``: their turned v_pref): record
    each one's ``turn`` (radians, + = left) and ``heading`` (its unit v_pref); turn every
    other active agent's v_pref by the turn it keeps, into ``out``."""
    for i in range(vpref.shape[0]):
        vx, vy = vpref[i, 0], vpref[i, 1]
        if due[i]:
            sp = np.sqrt(vx * vx + vy * vy)
            ux, uy = (vx / sp, vy / sp) if sp > 0.0 else (0.0, 0.0)
            ox, oy = out[i, 0], out[i, 1]
            turn[i] = np.arctan2(ux * oy - uy * ox, ux * ox + uy * oy)
            heading[i, 0], heading[i, 1] = ux, uy
        elif active[i] and turn[i] != 0.0:
            c, s = np.cos(turn[i]), np.sin(turn[i])
            out[i, 0] = c * vx - s * vy
            out[i, 1] = s * vx + c * vy


@njit(cache=True)
def turned_in(vpref, goals, pos, vel, radius, person_max_r, accel, out):
    """``out``: ``vpref`` of each walker (radius up to ``person_max_r``) slowed so that it
    can turn in to its goal at the comfortable acceleration ``accel`` instead of circling
    it: the circle through the goal tangent to its velocity has radius d / (2 sin θ) (d
    the distance, θ the angle off the goal, up to 90°; over 90° counts as 90°), and a turn
    of radius v² / a needs v ≤ √(a d / (2 sin θ)). Wider bodies keep ``vpref``."""
    for i in range(vpref.shape[0]):
        vx, vy = vpref[i, 0], vpref[i, 1]
        f = 1.0
        if radius[i] <= person_max_r:
            tx, ty = goals[i, 0] - pos[i, 0], goals[i, 1] - pos[i, 1]
            d = np.sqrt(tx * tx + ty * ty)
            sp = np.sqrt(vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
            cos = (tx * vel[i, 0] + ty * vel[i, 1]) / max(d * sp, 1e-12)
            sin = np.sqrt(min(max(1.0 - cos * cos, 0.0), 1.0)) if cos > 0.0 else 1.0
            cap = np.sqrt(accel * d / (2.0 * max(sin, 1e-6)))
            f = min(1.0, cap / max(np.sqrt(vx * vx + vy * vy), 1e-12))
        out[i, 0] = vx * f
        out[i, 1] = vy * f
