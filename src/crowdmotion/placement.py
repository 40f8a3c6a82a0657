"""Start positions for a group: inside its spawn region, clear of obstacles and of each other.

Shared by every method that places bodies in continuous space (RVO, PSO).
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Group, Points
from crowdmotion.scene import Scene


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
    n0 = len(placed)
    pts = np.empty((n0 + group.count, dim))
    rads = np.empty(n0 + group.count)
    pts[:n0], rads[:n0] = placed, placed_r
    m = n0
    tries = 0
    while m < n0 + group.count:
        tries += 1
        if tries > 200:
            raise ValueError(f"{what}: could not place {group.count} agents of radius {r} m without overlap in "
                             f"{group.spawn!r} (placed {m - n0}); enlarge the region or reduce the count")
        cand = group.spawn.sample(4 * (n0 + group.count - m) + 8, rng)
        cand = cand[scene.obstacle_distance(cand, 0.0) >= r + gap]
        if overlap:
            take = cand[: n0 + group.count - m]
            pts[m:m + len(take)], rads[m:m + len(take)] = take, r
            m += len(take)
            continue
        for c in cand:
            if m == n0 + group.count:
                break
            if m and np.any(np.linalg.norm(pts[:m] - c, axis=1) < rads[:m] + r + gap):
                continue
            pts[m], rads[m] = c, r
            m += 1
    return pts[n0:].copy()
