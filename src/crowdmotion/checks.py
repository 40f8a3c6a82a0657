"""Refusals every method shares before it simulates: the method's dimension, goals inside
obstacles, and spawn regions too small for their groups. Messages name the group, the
field and the value in the scenario file's own terms (``groups 'walkers' goal: ...``).
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Disc, Group, MovingTarget, Points, Rect
from crowdmotion.scene import Box, Polygon, Scene

# random sequential placement of discs jams at 54.7 % of the area (Feder 1980); ask for
# no more than this share so that sampling with rejection finds room quickly
PLACEABLE_SHARE = 0.5


def where(k: int, group: Group) -> str:
    """How messages name a group: ``group 'walkers' (groups.0)``."""
    return f"group {group.name!r} (groups.{k})"


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:g}" for x in np.asarray(v, float).ravel()) + "]"


def describe_region(region) -> str:
    """A spawn/goal region as the scenario file writes it."""
    if isinstance(region, Rect):
        return f"rect {_fmt(region.lower)}-{_fmt(region.upper)}"
    if isinstance(region, Disc):
        return f"disc centre {_fmt(region.center)} radius {region.radius:g}"
    if isinstance(region, Points):
        return f"point {_fmt(region.points[0])}" if len(region.points) == 1 else f"{len(region.points)} points"
    if isinstance(region, MovingTarget):
        return f"moving target ({len(region.times)} keyframes)"
    return repr(region)


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
    """Refuse goal points a body of the group's radius cannot stand on, and goal regions
    with no such spot (static obstacles at t = 0)."""
    goal = group.goal
    if isinstance(goal, MovingTarget):
        return
    pts = goal.points if isinstance(goal, Points) else region_samples(scene, goal)
    if len(pts) == 0:
        raise ValueError(f"{where(k, group)} goal: {describe_region(goal)} lies outside scene.bounds")
    clear = _clearance(scene, pts)
    if isinstance(goal, Points):
        bad = np.flatnonzero(clear < group.radius)
        if len(bad):
            p, c = pts[bad[0]], clear[bad[0]]
            if not scene.contains(p[None])[0]:
                how = f"lies outside scene.bounds {_fmt(scene.lower)}-{_fmt(scene.upper)}"
            else:
                how = f"lies inside {_blocker(scene, p)}" if c < 0 else f"is only {c:.3g} m from {_blocker(scene, p)}"
            raise ValueError(f"{where(k, group)} goal: the point {_fmt(p)} {how}: an agent of radius "
                             f"{group.radius:g} m cannot stand there")
    elif not np.any(clear >= group.radius):
        raise ValueError(f"{where(k, group)} goal: {describe_region(goal)} is covered by obstacles: no spot in it "
                         f"keeps an agent of radius {group.radius:g} m clear")


def check_spawn_capacity(scene: Scene, k: int, group: Group, gap: float) -> None:
    """Refuse a spawn region that cannot hold the group's bodies ``gap`` apart (by area)."""
    spawn = group.spawn
    if isinstance(spawn, Points):
        if len(spawn.points) != group.count:
            raise ValueError(f"{where(k, group)} spawn: {len(spawn.points)} points given for count = {group.count}")
        return
    pts, cell_area = region_samples(scene, spawn, with_area=True)
    free = float(np.sum(_clearance(scene, pts) >= group.radius + gap) * cell_area)
    body = np.pi * (group.radius + gap / 2) ** (2 if scene.dim == 2 else 3) * (1 if scene.dim == 2 else 4 / 3)
    room = int(PLACEABLE_SHARE * free / body)
    if group.count > room:
        unit = "m²" if scene.dim == 2 else "m³"
        raise ValueError(f"{where(k, group)} spawn: {describe_region(spawn)} has room for about {room} agents of "
                         f"radius {group.radius:g} m ({free:.3g} {unit} free of obstacles), but count = "
                         f"{group.count}: enlarge the spawn region or lower the count")


def region_samples(scene: Scene, region, with_area: bool = False):
    """Points of a regular lattice filling ``region`` within the scene bounds (and the area
    or volume each stands for, with ``with_area``)."""
    lo, hi = (region.lower, region.upper) if isinstance(region, Rect) else \
        (region.center - region.radius, region.center + region.radius)
    lo, hi = np.maximum(lo, scene.lower), np.minimum(hi, scene.upper)
    if np.any(hi <= lo):
        return (np.empty((0, scene.dim)), 0.0) if with_area else np.empty((0, scene.dim))
    n = 200 if scene.dim == 2 else 40
    axes = [lo[d] + (np.arange(n) + 0.5) * (hi[d] - lo[d]) / n for d in range(scene.dim)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, scene.dim)
    pts = pts[region.contains(pts)]
    if not with_area:
        return pts
    return pts, float(np.prod((hi - lo) / n))


def _clearance(scene: Scene, pts: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest static obstacle or the scene's walls."""
    walls = np.minimum(pts - scene.lower, scene.upper - pts).min(axis=1)
    return np.minimum(walls, scene.static_obstacle_distance(pts))


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
