"""Where bodies stand: start positions for a group (inside its spawn region, clear of
obstacles and of each other), and goal points and formation centres moved to where the
bodies fit.

Shared by every method that places bodies in continuous space (RVO, PSO, formation).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from crowdmotion.groups import Group, Lattice, Points, describe_region
from crowdmotion.scene import Scene


def _greedy_clear(cand: np.ndarray, r: float, gap: float, placed: np.ndarray, placed_r: np.ndarray) -> np.ndarray:
    """Mask of candidates kept when taken in order, each dropped if it overlaps a placed
    body or an earlier kept candidate (bodies ``gap`` apart)."""
    keep = np.ones(len(cand), dtype=bool)
    if len(placed):
        reach = r + float(placed_r.max()) + gap
        near = cKDTree(cand).sparse_distance_matrix(cKDTree(placed), reach, output_type="coo_matrix")
        bad = near.data < r + placed_r[near.col] + gap
        keep[near.row[bad]] = False
    pairs = cKDTree(cand).query_pairs(2 * r + gap, output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(cand[pairs[:, 0]] - cand[pairs[:, 1]], axis=1)
        pairs = pairs[d < 2 * r + gap]
        pairs = pairs[np.lexsort((pairs[:, 0], pairs[:, 1]))]  # by later index: earlier fates are settled
        for a, b in pairs:
            if keep[a] and keep[b]:
                keep[b] = False
    return keep


def spawn_positions(scene: Scene, group: Group, placed: np.ndarray, placed_r: np.ndarray, gap: float,
                    rng: np.random.Generator, overlap: bool = False) -> np.ndarray:
    """Start positions (count, dim) in the group's spawn region, clear of obstacles.

    Points are used as given (overlaps are then reported by the method); regions are
    sampled with rejection, in batches, keeping ``gap`` metres between bodies and between
    bodies and obstacles. ``placed``/``placed_r`` are bodies already in the scene (other
    groups). With ``overlap=True`` bodies may overlap each other (only obstacles are kept
    clear), for methods whose agents are points.
    """
    what = f"group {group.name!r} spawn"
    r = group.radius
    dim = scene.dim
    if isinstance(group.spawn, Points):
        if len(group.spawn.points) != group.count:
            raise ValueError(f"{what}: {len(group.spawn.points)} points given for {group.count} agents")
        return group.spawn.points.copy()
    placed = np.asarray(placed, dtype=float).reshape(-1, dim)
    placed_r = np.asarray(placed_r, dtype=float).reshape(-1)
    if isinstance(group.spawn, Lattice):
        return lattice_positions(scene, group, placed, placed_r, gap, rng)
    out = np.empty((0, dim))
    clear_ever = False  # whether any draw kept its body clear of the bounds and obstacles
    for _ in range(200):
        need = group.count - len(out)
        if need == 0:
            return out
        cand = group.spawn.sample(4 * need + 8, rng)
        inside = np.minimum(cand - scene.lower, scene.upper - cand).min(axis=1) >= r  # the body within the bounds
        cand = cand[inside]
        cand = cand[scene.obstacle_distance(cand, 0.0) >= r + gap]
        clear_ever |= len(cand) > 0
        if not overlap and len(cand):
            others = np.concatenate([placed, out])
            others_r = np.concatenate([placed_r, np.full(len(out), r)])
            cand = cand[_greedy_clear(cand, r, gap, others, others_r)]
        out = np.concatenate([out, cand[:need]])
    if not clear_ever:
        raise ValueError(f"{what}: {describe_region(group.spawn)} lies in obstacles or along the scene's edge: no "
                         f"point of it keeps a body of radius {r} m inside the bounds and {gap:g} m clear of the "
                         f"obstacles")
    raise ValueError(f"{what}: could not place {group.count} agents of radius {r} m without overlap in "
                     f"{group.spawn!r} (placed {len(out)}; a body keeps its radius inside the scene's bounds and "
                     f"clear of obstacles); enlarge the region or reduce the count")


#: the lattice's placements tried at each spacing, in the rectangle and in the part of it where
#: bodies fit: centred, and shifted by these fractions of a spacing across and of a row pair
#: up (walls and obstacles cut rows: the placement keeping most sites is taken)
LATTICE_PHASES = (None,) + tuple((fx, fy) for fx in (0.0, 0.5) for fy in (0.0, 0.25, 0.5, 0.75))
LATTICE_PROBE_M = 0.02  # the grid on which the part of the rectangle where bodies fit is found ...
LATTICE_PROBE_MAX = 400  # ... with at most this many points a side


def _clear_of(scene: Scene, need: float, placed: np.ndarray | None, placed_r: np.ndarray | None, clearance):
    """``clear(points)``: whether a body at each point stands ``need`` metres (its radius and
    the gap) clear of obstacles (at t = 0), of the scene's bounds, of the ``placed`` bodies
    (radii ``placed_r``) and, with ``clearance(points)``, of further obstacles."""
    tree = cKDTree(placed) if placed is not None and len(placed) else None
    room = need - 1e-9  # (a site exactly a body and the gap from a wall fits)

    def clear(pts: np.ndarray) -> np.ndarray:
        ok = (scene.obstacle_distance(pts, 0.0) >= room) & (scene.wall_clearance(pts) >= room)
        if clearance is not None and ok.any():
            ok &= clearance(pts) >= room
        if tree is not None and ok.any():
            d, j = tree.query(pts, k=1)
            ok &= d >= room + placed_r[j]
        return ok

    return clear


def _lattice_boxes(lattice: Lattice, clear) -> list:
    """Where to lay a lattice out: the rectangle (None), and the part of it where a body
    fits (found on a probe grid of LATTICE_PROBE_M, at most LATTICE_PROBE_MAX points a
    side, and grown by a probe step within the rectangle: sites where none fits are
    dropped anyway)."""
    size = lattice.upper - lattice.lower
    steps = np.minimum(np.maximum(np.ceil(size / LATTICE_PROBE_M).astype(int), 1) + 1, LATTICE_PROBE_MAX)
    probe = np.stack(np.meshgrid(*(np.linspace(lo, hi, k) for lo, hi, k in zip(lattice.lower, lattice.upper, steps)),
                                 indexing="ij"), axis=-1).reshape(-1, 2)
    fit = probe[clear(probe)]
    if not len(fit):
        return [None]
    step = size / np.maximum(steps - 1, 1)
    return [None, (np.maximum(fit.min(axis=0) - step, lattice.lower),
                   np.minimum(fit.max(axis=0) + step, lattice.upper))]


def _most_sites(lattice: Lattice, spacing: float, clear, boxes: list) -> np.ndarray:
    """(m, 2) the most sites of ``lattice`` at ``spacing`` metres that ``clear`` keeps, over
    the placements ``LATTICE_PHASES`` in each of ``boxes`` (:func:`_lattice_boxes`)."""
    best = np.empty((0, 2))
    for within in boxes:
        for phase in LATTICE_PHASES:
            pts = lattice.sites(spacing, phase, within)
            if len(pts) <= len(best):
                continue
            ok = clear(pts)
            if ok.sum() > len(best):
                best = pts[ok]
    return best


def lattice_sites(scene: Scene, group: Group, gap: float, spacing: float, placed: np.ndarray | None = None,
                  placed_r: np.ndarray | None = None, clearance=None) -> np.ndarray:
    """(m, 2) the most sites of the group's :class:`~crowdmotion.groups.Lattice` at
    ``spacing`` metres, over the placements ``LATTICE_PHASES``, where a body of its radius
    stands ``gap`` clear of obstacles (at t = 0), of the scene's bounds, of the ``placed``
    bodies (radii ``placed_r``) and, with ``clearance(points)``, of further obstacles."""
    clear = _clear_of(scene, group.radius + gap, placed, placed_r, clearance)
    return _most_sites(group.spawn, spacing, clear, _lattice_boxes(group.spawn, clear))


def lattice_positions(scene: Scene, group: Group, placed: np.ndarray, placed_r: np.ndarray, gap: float,
                      rng: np.random.Generator) -> np.ndarray:
    """Start positions (count, 2) on the group's :class:`~crowdmotion.groups.Lattice`: the
    widest lattice spacing (found by bisection, to 0.1 %) whose clear sites
    (:func:`lattice_sites`) number at least the count; where that leaves more sites than
    agents, the spare ones (a part of a row) are left empty at random. A ValueError naming
    the most that fit when even the closest spacing, bodies ``gap`` apart, holds too few."""
    lattice, n = group.spawn, group.count
    clear = _clear_of(scene, group.radius + gap, placed, placed_r, None)  # (its tree built once, not per spacing)
    boxes = _lattice_boxes(lattice, clear)

    def sites(spacing: float) -> np.ndarray:
        return _most_sites(lattice, spacing, clear, boxes)

    closest = 2.0 * group.radius + gap
    most = len(sites(closest))
    if most < n:
        raise ValueError(f"group {group.name!r} spawn: {describe_region(lattice)} holds at most {most} agents of "
                         f"radius {group.radius:g} m, {gap:g} m apart (clear of walls and other groups), but count "
                         f"= {n}: enlarge the lattice or lower the count")
    lo, hi = closest, closest + float(np.hypot(*(lattice.upper - lattice.lower))) + 1.0
    widest = sites(hi)
    if len(widest) >= n:  # one agent: a spacing wider than the rectangle leaves its centre
        return widest[:n]
    while hi - lo > 1e-3 * lo:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if len(sites(mid)) >= n else (lo, mid)
    found = sites(lo)
    keep = np.sort(rng.choice(len(found), size=n, replace=False)) if len(found) > n else np.arange(n)
    return found[keep]


#: a goal point moved clear of a wall keeps this much more than the body's radius from it
GOAL_CLEARANCE_M = 0.02


def standing_points(scene: Scene, points: np.ndarray, radius, steps: int = 8) -> np.ndarray:
    """``points`` (n, dim) where a body of ``radius`` (one for all, or one each) cannot
    stand, closer to the scene's bounds or a static obstacle than the radius, each moved
    the least way to where it fits with GOAL_CLEARANCE_M to spare (off obstacles along
    their signed distance, a few steps for corners). Points where the body stands are
    returned as they are; where no place is near enough (a gap narrower than the body),
    the nearest found.

    A goal point sampled in an exit strip along the scene's edge may lie closer to the
    edge than the agent's radius: no body gets there, and eq. (3) counts the wall it
    would meet before its goal, so the agent stops metres short and stands for good."""
    pts = np.array(points, dtype=float, copy=True)
    if len(pts) == 0:
        return pts
    r = np.broadcast_to(np.asarray(radius, dtype=float), (len(pts),))[:, None]
    need = r + GOAL_CLEARANCE_M
    mid = 0.5 * (scene.lower + scene.upper)

    def inside_bounds(p):
        low, high = p < scene.lower + r, p > scene.upper - r  # the body sticks out
        p = np.where(low, scene.lower + need, np.where(high, scene.upper - need, p))
        narrow = scene.lower + need > scene.upper - need  # a scene narrower than the body: its middle
        return np.where((low | high) & narrow, mid, p)

    pts = inside_bounds(pts)
    eps = 1e-4
    for _ in range(steps):
        if not scene.static_obstacles:
            break
        d = scene.static_obstacle_distance(pts)
        bad = np.flatnonzero(d < r[:, 0])
        if len(bad) == 0:
            break
        grad = np.empty((len(bad), pts.shape[1]))
        for axis in range(pts.shape[1]):
            step = np.zeros(pts.shape[1])
            step[axis] = eps
            grad[:, axis] = (scene.static_obstacle_distance(pts[bad] + step)
                             - scene.static_obstacle_distance(pts[bad] - step)) / (2 * eps)
        norm = np.linalg.norm(grad, axis=1)
        ok = norm > 1e-9
        pts[bad[ok]] += (need[bad[ok], 0] - d[bad[ok]])[:, None] * grad[ok] / norm[ok, None]
        pts = inside_bounds(pts)
    return pts


def standing_centre(scene: Scene, centre: np.ndarray, offsets: np.ndarray, clearance: float,
                    step: float = 0.1, reach: float | None = None, obstacles: bool = True) -> np.ndarray:
    """``centre`` (2D) moved the least way so that a rigid set of bodies at ``centre +
    offsets`` keeps ``clearance`` from the scene's bounds and every static obstacle: the
    place a whole formation can stand, where :func:`standing_points` places one body.

    Bounds bind exactly (a shape wider than the scene stands in its middle along that
    axis). Obstacles: candidate centres on rings ``step`` apart round it, out to
    ``reach`` (default: the shape's size plus 2 m), 72 directions each; the nearest
    where every body fits, refined to a hundredth of ``step`` along its direction. Where
    none fits, the candidate cutting least into the obstacles. ``centre`` comes back as
    it is where every body fits. (The signed distance's gradient alone does not do: a
    body in the middle of a box has none, and it would push through to the far side.)"""
    c = np.array(centre, dtype=float, copy=True)
    off = np.asarray(offsets, dtype=float).reshape(-1, len(c))
    low = scene.lower + clearance - off.min(axis=0)
    high = scene.upper - clearance - off.max(axis=0)

    def inside_bounds(x):
        return np.where(low > high, 0.5 * (low + high), np.clip(x, low, np.maximum(low, high)))

    def cut(cands):  # (k,) how far the bodies at each candidate centre reach into the obstacles
        d = scene.static_obstacle_distance((cands[:, None, :] + off[None]).reshape(-1, len(c)))
        return np.maximum(clearance - d.reshape(len(cands), len(off)), 0.0).sum(axis=1)

    c = inside_bounds(c)
    if not obstacles or not scene.static_obstacles or cut(c[None])[0] <= 0.0:
        return c
    reach = float(np.ptp(off, axis=0).max()) + 2.0 if reach is None else reach
    angles = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    dirs = np.zeros((len(angles), len(c)))
    dirs[:, 0], dirs[:, 1] = np.cos(angles), np.sin(angles)
    best, least = c, np.inf
    for r in np.arange(1, int(np.ceil(reach / step)) + 1) * step:
        cands = inside_bounds(c + r * dirs)
        k = cut(cands)
        if (k <= 0.0).any():
            u = dirs[int(np.argmin(np.where(k <= 0.0, 0.0, np.inf)))]  # first fitting direction
            lo, hi = r - step, r
            while hi - lo > 0.01 * step:  # bisect to the nearest fitting distance along it
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if cut(inside_bounds(c + mid * u)[None])[0] <= 0.0 else (mid, hi)
            return inside_bounds(c + hi * u)
        if k.min() < least:
            best, least = cands[int(np.argmin(k))], float(k.min())
    return best


def spawn_groups(scene: Scene, groups, gap: float, rng: np.random.Generator, overlap: bool = False):
    """Start positions of every group in turn, each clear of the groups placed before it:
    (positions (N, dim), radius (N,), group index (N,))."""
    xs, rs, gi = np.empty((0, scene.dim)), np.empty(0), []
    for k, g in enumerate(groups):
        p = spawn_positions(scene, g, xs, rs, gap, rng, overlap=overlap)
        xs, rs = np.concatenate([xs, p]), np.concatenate([rs, np.full(len(p), g.radius)])
        gi += [k] * len(p)
    return xs, rs, np.array(gi, dtype=np.int64)
