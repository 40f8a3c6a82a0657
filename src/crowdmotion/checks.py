"""Refusals every method shares before it simulates: the method's dimension, goals inside
obstacles or outside the bounds, spawn regions too small for their groups, listed starts
that overlap or stand in obstacles, and goals walled off from their spawns. Messages name
the group, the field and the value in the scenario file's own terms (``groups 'walkers'
goal: ...``).
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Disc, Group, Lattice, MovingTarget, Points, Rect, describe_region  # noqa: F401 (re-exported)
from crowdmotion.placement import lattice_sites
from crowdmotion.scene import Box, Polygon, Scene

def group_problems(groups, check) -> None:
    """Run ``check(k, group)`` on every group and refuse them all at once: a ValueError
    listing each group's first problem (a file with two groups wrong said only the first,
    and the user fixed one per run); one problem raises as it is."""
    found = []
    for k, g in enumerate(groups):
        try:
            check(k, g)
        except ValueError as exc:
            found.append(str(exc))
    if len(found) == 1:
        raise ValueError(found[0])
    if found:
        raise ValueError(f"{len(found)} problems:\n  " + "\n  ".join(found))


def where(k: int, group: Group) -> str:
    """How messages name a group: ``group 'walkers' (groups.0)``."""
    return f"group {group.name!r} (groups.{k})"


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in np.asarray(v, float).ravel()) + "]"


def describe_obstacle(scene: Scene, index: int) -> str:
    """``scene.obstacles.3 (box [20, 5]-[25, 15])``."""
    ob = scene.obstacles[index]
    if isinstance(ob, Box):
        shape = f"box {_fmt(ob.lower)}-{_fmt(ob.upper)}"
    elif isinstance(ob, Polygon):
        shape = f"polygon of {len(ob.vertices)} vertices"
    else:
        shape = f"{type(ob).__name__.lower()} centre {_fmt(ob.center)} radius {ob.radius:g}"
    return f"scene.obstacles.{index} ({shape})"


def check_dimension(method: str, scene: Scene, supported: tuple[int, ...], alternatives: str) -> None:
    """Refuse a scene whose dimension the method does not handle."""
    if scene.dim not in supported:
        dims = " or ".join(f"{d}D" for d in supported)
        raise ValueError(f"method {method!r} works in {dims}, but the scene is {scene.dim}D "
                         f"(scene.bounds has {scene.dim} coordinates); {alternatives}")


def check_goal_clear(scene: Scene, k: int, group: Group) -> None:
    """Refuse goal points a body of the group's radius cannot stand on, goal regions with
    no such spot (static obstacles at t = 0), and a moving goal that leaves the bounds."""
    goal = group.goal
    if isinstance(goal, MovingTarget):
        out = np.flatnonzero(~scene.contains(goal.positions))
        if len(out):
            raise ValueError(f"{where(k, group)} goal: the moving target's keyframe {int(out[0])} at "
                             f"{_fmt(goal.positions[out[0]])} lies outside scene.bounds {_fmt(scene.lower)}-"
                             f"{_fmt(scene.upper)}")
        return
    pts = goal.points if isinstance(goal, Points) else region_samples(scene, goal)
    if len(pts) == 0:
        raise ValueError(f"{where(k, group)} goal: {describe_region(goal)} lies outside scene.bounds")
    clear = scene.clearance(pts)
    if isinstance(goal, Points):
        _refuse_unfit(scene, k, group, "goal", pts, clear, "stand")
    elif not np.any(clear >= group.radius):
        best = int(np.argmax(clear))
        raise ValueError(f"{where(k, group)} goal: no spot in {describe_region(goal)} keeps an agent of radius "
                         f"{group.radius:g} m clear: its best, {_fmt(pts[best])}, "
                         f"{_why_unfit(scene, pts[best], clear[best])}")


#: about how many points sample a spawn region (and the region grown by a body) when its
#: room is counted; cells are near cubes, one layer across an axis the region is flat along
ROOM_SAMPLES = {2: 40_000, 3: 64_000}


def _ball(dim: int, radius: float) -> float:
    """Area (2D) or volume (3D) of a disc or ball of ``radius``."""
    return np.pi * radius ** 2 if dim == 2 else 4 / 3 * np.pi * radius ** 3


def _grid(lo: np.ndarray, hi: np.ndarray, total: int) -> tuple[np.ndarray, np.ndarray]:
    """(points, cell sizes) of a lattice of about ``total`` near-cubic cells filling the
    box ``lo``-``hi``, a cell's centre each; one layer (cell size 0) along an axis where
    the box is flat."""
    size = hi - lo
    wide = size > 0
    step = float(np.prod(size[wide]) / total) ** (1 / max(int(wide.sum()), 1)) if wide.any() else 1.0
    n = np.where(wide, np.clip(np.round(size / step), 1, total), 1).astype(int)
    cell = size / n
    axes = [lo[d] + (np.arange(n[d]) + 0.5) * cell[d] for d in range(len(lo))]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(lo)), cell


def spawn_room(scene: Scene, group: Group, gap: float, clearance=None) -> tuple[int, float]:
    """(the most bodies of the group that fit ``gap`` apart in its spawn region, the
    measure where their centres may stand: an area in 2D, a volume in 3D, an area or a
    length for a region flat along one or two axes). ``clearance(points)``: distances to
    further obstacles, beyond the scene's own.

    Centres may stand where :func:`~crowdmotion.placement.spawn_positions` takes them:
    in the region, the body inside the bounds, its radius and the gap clear of obstacles.
    The count is a packing bound, so that a refusal never turns down what fits: discs
    (balls) of diameter s = 2 radius + gap round the centres do not overlap, and lie in
    the centres' set grown by s / 2, so no more of them fit than that grown measure
    over one's. A region thinner than a body (a launch pad in a 3D scene, even a flat
    one) is so judged by its area, one layer of bodies side by side, not by its volume
    (the sampled regions' old estimate, half their free volume over a body's, refused
    50 drones on a 20 x 10 m pad 0.1 m thick: "room for about 34")."""
    if isinstance(group.spawn, Lattice):  # exactly: the sites clear at the closest spacing
        free = float(np.prod(group.spawn.upper - group.spawn.lower))
        return len(lattice_sites(scene, group, gap, 2.0 * group.radius + gap, clearance=clearance)), free
    r, dim = group.radius, scene.dim
    region = group.spawn
    lo, hi = region_box(region)
    lo, hi = np.maximum(lo, scene.lower + r), np.minimum(hi, scene.upper - r)  # the body inside the bounds
    if np.any(hi < lo):
        return 0, 0.0
    total = ROOM_SAMPLES[dim]
    pts, cell = _grid(lo, hi, total)
    ok = region.contains(pts) & (scene.obstacle_distance(pts, 0.0) >= r + gap)
    if clearance is not None and ok.any():
        ok[ok] = clearance(pts[ok]) >= r + gap
    centres = pts[ok]
    free = float(len(centres) * np.prod(cell[cell > 0]))
    if not len(centres):
        return 0, free
    from scipy.spatial import cKDTree

    s = 2.0 * r + gap  # the grown set: within s / 2 of a centre, each sample standing for its cell
    probe, probe_cell = _grid(lo - s / 2, hi + s / 2, total)
    reach = s / 2 + 0.5 * float(np.linalg.norm(cell)) + 0.5 * float(np.linalg.norm(probe_cell))
    near = cKDTree(centres).query(probe, distance_upper_bound=reach)[0] <= reach
    grown = float(near.sum() * np.prod(probe_cell))
    return int(min(grown / _ball(dim, s / 2), 1e15)), free


def _room_at_least(scene: Scene, group: Group, gap: float) -> int:
    """A lower bound of :func:`spawn_room`'s count without sampling: the spawn region's
    box within the bounds, a body and the gap in from the walls, less the part inside it
    of every static obstacle's bounding box grown by as much (0 for a disc or sphere
    region), over a body's disc (ball) a gap wide: the centres' set holds that box's
    free part, and the grown set it."""
    region = group.spawn
    if not isinstance(region, Rect):
        return 0
    reach = group.radius + gap
    lo, hi = np.maximum(region.lower, scene.lower + reach), np.minimum(region.upper, scene.upper - reach)
    if np.any(hi <= lo):
        return 0
    free = float(np.prod(hi - lo))
    for ob in scene.static_obstacles:  # less the part of its grown box inside the region
        olo, ohi = ob.bounds()
        free -= float(np.prod(np.clip(np.minimum(hi, np.asarray(ohi) + reach) - np.maximum(lo, np.asarray(olo) - reach),
                                      0.0, None)))
    return int(max(0.9 * free / _ball(scene.dim, group.radius + gap / 2), 0.0))


def region_box(region) -> tuple[np.ndarray, np.ndarray] | None:
    """(lower, upper) corners of a rect or disc (sphere) region's bounding box; None for
    other regions (points, moving targets)."""
    if isinstance(region, Rect):
        return region.lower, region.upper
    if isinstance(region, Disc):
        return region.center - region.radius, region.center + region.radius
    return None


def check_inside(scene: Scene, k: int, group: Group, part: str = "spawn", region=None) -> None:
    """Refuse a spawn or goal region (rect or disc; ``part``) that reaches outside the
    scene's bounds, where sampled starts or goal points would lie outside the scene
    (``region``: another area to check under the name ``part``, an entrance say)."""
    region = getattr(group, part) if region is None else region
    box = region_box(region)
    if box is None:
        return
    lo, hi = box
    tol = 1e-9 * float(np.max(scene.upper - scene.lower))
    if np.any(lo < scene.lower - tol) or np.any(hi > scene.upper + tol):
        what = "goal points would lie outside the scene" if part == "goal" else "agents would start outside the scene"
        raise ValueError(f"{where(k, group)} {part}: {describe_region(region)} reaches outside scene.bounds "
                         f"{_fmt(scene.lower)}-{_fmt(scene.upper)}: {what}")


def check_entrances(scene: Scene, k: int, group: Group) -> None:
    """Refuse a group's entrances (``enter.entrances``) that reach outside the scene, each
    named."""
    from crowdmotion.journeys import entrance_areas

    for j, area in enumerate(entrance_areas(group.attributes.get("enter"))):
        check_inside(scene, k, group, f"enter.entrances.{j}", area)


def warn_late_entries(k: int, group: Group, run_end_s: float, setting: str) -> None:
    """Warn (UserWarning) when some of a group's agents are due to enter after the run
    ends (``run_end_s`` seconds, from ``setting``, e.g. "[rvo] max_steps x time_step"):
    they would never enter."""
    import warnings

    from crowdmotion.journeys import entry_times

    spec = group.attributes.get("enter")
    if spec is None:
        return
    due = entry_times(spec, group.count)
    late = int((due > run_end_s).sum())
    if late:
        warnings.warn(f"{where(k, group)} enter: {late} of {group.count} agents are due after the run ends at "
                      f"{run_end_s:g} s ({setting}), the last at {due.max():g} s; they never enter. Raise the run's "
                      f"length or enter them sooner", UserWarning, stacklevel=2)


def check_spawn_capacity(scene: Scene, k: int, group: Group, gap: float) -> None:
    """Refuse a spawn region that cannot hold the group's bodies ``gap`` apart (by a
    packing bound: :func:`spawn_room`)."""
    spawn = group.spawn
    if isinstance(spawn, Points):
        if len(spawn.points) != group.count:
            raise ValueError(f"{where(k, group)} spawn: {len(spawn.points)} points given for count = {group.count}")
        return
    if not isinstance(spawn, Lattice) and group.count <= _room_at_least(scene, group, gap):
        return  # room enough by a lower bound: no sampling needed
    room, free = spawn_room(scene, group, gap)
    if group.count > room:
        lo, hi = region_box(spawn)
        unit = ("m", "m", "m²", "m³")[int(np.sum(hi > lo))]
        if free <= 0.0:  # nothing of it is walkable: say where it lies, not how crowded it is
            raise ValueError(f"{where(k, group)} spawn: {describe_region(spawn)} has no free room: all of it lies in "
                             f"obstacles or within a body's radius ({group.radius:g} m) of them or of the scene's "
                             f"edge; move it into the free space")
        raise ValueError(f"{where(k, group)} spawn: {describe_region(spawn)} has room for at most {room} agents of "
                         f"radius {group.radius:g} m ({free:.3g} {unit} free of obstacles), but count = "
                         f"{group.count}: enlarge the spawn region or lower the count")


def check_start_points(scene: Scene, groups, apart: bool = True) -> None:
    """Refuse listed start points (spawn shape points or point) where a body of the
    group's radius leaves the bounds or stands in a static obstacle, and, with ``apart``,
    two bodies that overlap at the start (the same point given twice, say)."""
    from scipy.spatial import cKDTree

    pts, rad, owner = [], [], []
    for k, g in enumerate(groups):
        if not isinstance(g.spawn, Points):
            continue
        p = g.spawn.points
        _refuse_unfit(scene, k, g, "spawn", p, scene.clearance(p), "start")
        pts.append(p)
        rad.append(np.full(len(p), g.radius))
        owner += [(k, i) for i in range(len(p))]
    if not apart or not pts:
        return
    pts, rad = np.concatenate(pts), np.concatenate(rad)
    pairs = cKDTree(pts).query_pairs(2 * float(rad.max()), output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1)
        close = np.flatnonzero(d < rad[pairs[:, 0]] + rad[pairs[:, 1]])
        if len(close):
            a, b = (int(x) for x in pairs[close[np.argmin(d[close])]])
            (ka, ia), (kb, ib) = owner[a], owner[b]
            other = "" if ka == kb else f" {where(kb, groups[kb])}'s"
            radii = f"{rad[a]:g} m" if rad[a] == rad[b] else f"{rad[a]:g} m and {rad[b]:g} m"
            raise ValueError(f"{where(ka, groups[ka])} spawn: start points {ia} {_fmt(pts[a])} and{other} {ib} "
                             f"{_fmt(pts[b])} are {np.linalg.norm(pts[a] - pts[b]):.3g} m apart: agents of radius "
                             f"{radii} would overlap at the start")


# cells of the grid on which check_reachable looks for a way: as many as REACH_WORK
# cell-obstacle distances allow, within these bounds (a validate stays well under a second)
REACH_CELLS = (20_000, 250_000)
REACH_WORK = 4_000_000


def check_reachable(scene: Scene, k: int, group: Group) -> None:
    """Refuse a goal that static obstacles wall off from the whole spawn for a body of
    the group's radius. Looked for on a grid whose free cells are every cell that may
    hold a point clear of obstacles and walls by the radius (clearance is 1-Lipschitz,
    so a cell whose centre is within radius - half its diagonal holds none), joined
    across faces, edges and corners: a way in the plane always shows on the grid, so the
    grid never refuses a goal that can be reached."""
    from scipy import ndimage

    goal, spawn = group.goal, group.spawn
    if isinstance(goal, MovingTarget) or not scene.static_obstacles:
        return
    dim = scene.dim
    extent = scene.upper - scene.lower
    cells = min(max(REACH_WORK // len(scene.static_obstacles), REACH_CELLS[0]), REACH_CELLS[1])
    cell = float(max(group.radius / 2, (np.prod(extent) / cells) ** (1 / dim)))
    shape = tuple(int(n) for n in np.maximum(np.ceil(extent / cell - 1e-9), 1))
    idx = np.indices(shape).reshape(dim, -1).T
    centres = scene.lower + (idx + 0.5) * cell
    free = (scene.clearance(centres) >= group.radius - cell * np.sqrt(dim) / 2).reshape(shape)
    labels, _ = ndimage.label(free, structure=np.ones((3,) * dim))

    def parts(points) -> set:
        cells = np.clip(np.floor((points - scene.lower) / cell).astype(np.int64), 0, np.array(shape) - 1)
        found = labels[tuple(cells.T)]
        return set(found[found > 0].tolist())

    starts = spawn.points if isinstance(spawn, Points) else region_samples(scene, spawn)
    ends = goal.points if isinstance(goal, Points) else region_samples(scene, goal)
    if len(starts) and len(ends) and not parts(starts) & parts(ends):
        raise ValueError(f"{where(k, group)} goal: {describe_region(goal)} cannot be reached from the spawn "
                         f"{describe_region(spawn)}: obstacles close the way for a body of radius "
                         f"{group.radius:g} m")


def region_samples(scene: Scene, region) -> np.ndarray:
    """Points of a regular lattice filling ``region`` within the scene bounds; a region
    flat along an axis (a landing pad with lower z = upper z) is sampled in its plane."""
    lo, hi = region_box(region)
    lo, hi = np.maximum(lo, scene.lower), np.minimum(hi, scene.upper)
    if np.any(hi < lo):
        return np.empty((0, scene.dim))
    n = 200 if scene.dim == 2 else 40
    axes = [lo[d] + (np.arange(n) + 0.5) * (hi[d] - lo[d]) / n if hi[d] > lo[d] else lo[d:d + 1]
            for d in range(scene.dim)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, scene.dim)
    return pts[region.contains(pts)]


def _refuse_unfit(scene: Scene, k: int, group: Group, part: str, pts: np.ndarray, clear: np.ndarray,
                  verb: str) -> None:
    """Refuse the first of a group's listed ``part`` points (spawn or goal) whose
    clearance ``clear`` leaves no room for its body, saying why."""
    bad = np.flatnonzero(clear < group.radius)
    if len(bad):
        p = pts[bad[0]]
        raise ValueError(f"{where(k, group)} {part}: the point {_fmt(p)} {_why_unfit(scene, p, clear[bad[0]])}: an "
                         f"agent of radius {group.radius:g} m cannot {verb} there")


def _why_unfit(scene, p: np.ndarray, clear: float) -> str:
    """Why an agent cannot stand at point ``p`` (its clearance ``clear``, m): outside the
    bounds, inside an obstacle, or too near one (the obstacle named)."""
    if not scene.contains(p[None])[0]:
        return f"lies outside scene.bounds {_fmt(scene.lower)}-{_fmt(scene.upper)}"
    return f"lies inside {_blocker(scene, p)}" if clear < 0 else f"is only {clear:.3g} m from {_blocker(scene, p)}"


def _blocker(scene: Scene, p: np.ndarray) -> str:
    """Which static obstacle (or the scene's bounds) is nearest the point."""
    best, name = np.inf, "the walls of scene.bounds"
    for i, ob in enumerate(scene.obstacles):
        if ob.is_moving:
            continue
        d = float(ob.signed_distance(p[None])[0])
        if d < best:
            best, name = d, describe_obstacle(scene, i)
    walls = float(np.minimum(p - scene.lower, scene.upper - p).min())
    return name if best <= walls else "the walls of scene.bounds"


def check_route_places(scene: Scene, k: int, group: Group) -> None:
    """Refuse a route (``group.attributes["route"]``) whose areas reach outside the scene
    or have no spot a body fits in, or whose queue places (as many as the group has
    agents) leave the scene or stand in obstacles, or lie closer than a body apart. The
    stage is named: ``group 'riders' (groups.0) route.1 (queue 'gate'): ...``."""
    from dataclasses import replace

    from crowdmotion.stages import Queue, flat_stages, stage_label

    for path, st, _ in flat_stages(group.attributes.get("route") or []):
        at = f"{where(k, group)} {stage_label(path, st)}"
        area = getattr(st, "area", None)
        if area is not None:
            probe = replace(group, goal=area)
            try:
                check_inside(scene, k, probe, "goal")
                check_goal_clear(scene, k, probe)
            except ValueError as exc:
                raise ValueError(str(exc).replace(f"{where(k, group)} goal:", f"{at} area:")) from None
        if isinstance(st, Queue):
            if st.spacing < 2 * group.radius:
                raise ValueError(f"{at}: spacing {st.spacing:g} m is less than a body ({2 * group.radius:g} m, "
                                 f"twice the radius): people in line would overlap")
            slots = st.slots(group.count)
            clear = scene.clearance(slots)
            bad = np.flatnonzero(clear < group.radius)
            if len(bad) and bad[0] == 0:  # the head itself: no line would help
                raise ValueError(f"{at}: its head {_fmt(slots[0])} {_why_unfit(scene, slots[0], clear[0])}: put the "
                                 f"head where a body of radius {group.radius:g} m stands clear, in front of the "
                                 f"counter or desk")
            if len(bad):
                i = int(bad[0])
                raise ValueError(f"{at}: place {i} in line at {_fmt(slots[i])} {_why_unfit(scene, slots[i], clear[i])}"
                                 f": a line of {group.count} (the group's count) needs room for a body of radius "
                                 f"{group.radius:g} m every {st.spacing:g} m; give the queue a line that turns "
                                 f"(line = [[x, y], ...]) or more room")


def check_live_route(scene: Scene, route, count: int, radius: float, at, what: str) -> None:
    """A route set while running (the live API) checked against the scene standing now as
    a scenario's route is (:func:`check_route_places`, for ``count`` bodies of ``radius``
    now at the point ``at``); the message begins ``what:``, then names the stage."""
    here = np.asarray(at, float).reshape(1, 2)
    probe = Group(what, count, Points(here), Points(here), radius=float(radius), attributes={"route": route})
    try:
        check_route_places(scene, 0, probe)
    except ValueError as exc:
        raise ValueError(str(exc).replace(f"{where(0, probe)} ", f"{what}: ")) from None
