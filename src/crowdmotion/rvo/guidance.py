"""Global guidance for RVO: preferred velocities straight at the goal or along an exact
MDP distance field (``crowdmotion.mdp``) when obstacles stand between."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crowdmotion.groups import MovingTarget, Points
from crowdmotion.mdp.solvers import fast_values
from crowdmotion.rvo import _kernels as K
from crowdmotion.obstacle_primitives import ObstaclePrimitives
from crowdmotion.scene import Scene

MAX_FIELD_CELLS = 16_000_000
FIELD_WINDOW = 2  # cells: agents aim within this many cells along the field


@dataclass
class DistanceFields:
    """Metres to each goal region along free space, on one grid: (F, nx, ny), inf = blocked."""

    dist: np.ndarray
    origin: np.ndarray
    cell: float
    blocked: np.ndarray | None = None  # (nx, ny) cells a body does not fit in
    goal_cells: list | None = None     # per field, (K, 2) goal cells

    def at(self, field: int, points: np.ndarray) -> np.ndarray:
        """Field values at the cells holding ``points`` (inf outside the grid)."""
        idx = np.floor((np.asarray(points) - self.origin) / self.cell).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < np.array(self.dist.shape[1:])), axis=1)
        out = np.full(len(idx), np.inf)
        out[inside] = self.dist[field, idx[inside, 0], idx[inside, 1]]
        return out


    def reachable(self, field_of: np.ndarray, points: np.ndarray, window: int = 2) -> np.ndarray:
        """Whether some cell within ``window`` cells of each point has a finite distance
        to the point's goal (field ``field_of``)."""
        shape = np.array(self.dist.shape[1:])
        idx = np.floor((np.asarray(points) - self.origin) / self.cell).astype(np.int64)
        out = np.zeros(len(idx), dtype=bool)
        for dx in range(-window, window + 1):
            for dy in range(-window, window + 1):
                c = idx + [dx, dy]
                inside = np.all((c >= 0) & (c < shape), axis=1)
                ok = np.zeros(len(idx), dtype=bool)
                ok[inside] = np.isfinite(self.dist[field_of[inside], c[inside, 0], c[inside, 1]])
                out |= ok
        return out


def default_cell(scene: Scene, radius: float) -> float:
    """Field cell edge: the agent radius, coarsened so the grid stays under 4M cells."""
    extent = scene.upper - scene.lower
    return float(max(radius, np.sqrt(np.prod(extent) / 4e6)))


def distance_fields(scene: Scene, goals: list, radius: float, cell: float | None = None) -> DistanceFields:
    """Exact 8-connected distances (corner cutting off) to each goal region, in metres.

    A cell is blocked when its centre lies within ``radius`` of a static obstacle, so the
    field routes agents' centres where their bodies fit. Goals are regions (their free
    cells) or Points (the cells of the points).
    """
    cell = default_cell(scene, radius) if cell is None else float(cell)
    if not (np.isfinite(cell) and cell > 0):
        raise ValueError(f"rvo.field_cell must be a positive number of metres, got {cell!r}")
    extent = scene.upper - scene.lower
    shape = tuple(int(n) for n in np.maximum(np.ceil(extent / cell - 1e-9), 1))
    if np.prod(shape) > MAX_FIELD_CELLS:
        raise ValueError(f"rvo.field_cell {cell} m gives a {shape} grid; use a larger cell")
    idx = np.indices(shape).reshape(2, -1).T
    centres = scene.lower + (idx + 0.5) * cell
    blocked = (scene.static_obstacle_distance(centres) < radius).reshape(shape)
    fields, goal_cells = [], []
    for k, goal in enumerate(goals):
        if isinstance(goal, MovingTarget):
            raise ValueError(f"groups.{k}: field guidance needs a fixed goal, not a moving target")
        if isinstance(goal, Points):
            gi = np.floor((goal.points - scene.lower) / cell).astype(np.int64)
            gi = np.clip(gi, 0, np.array(shape) - 1)
            cells = [tuple(c) for c in gi if not blocked[tuple(c)]]
        else:
            inside = goal.contains(centres).reshape(shape) & ~blocked
            cells = [tuple(c) for c in np.argwhere(inside)]
        if not cells:
            raise ValueError(f"groups.{k}: the goal {goal!r} has no cell free of obstacles "
                             f"(field cell {cell:.3f} m, agent radius {radius} m)")
        cells = sorted(set(cells))
        v = fast_values(blocked.astype(np.uint8), cells, corner_cutting=False)
        fields.append(-v * cell)
        goal_cells.append(np.array(cells, dtype=np.int64))
    return DistanceFields(np.stack(fields), scene.lower.astype(float).copy(), cell, blocked, goal_cells)


def preferred_velocities(pos, goal, pref_speed, active, dt, fields: DistanceFields | None, field_of,
                         prims: ObstaclePrimitives, radius) -> tuple[np.ndarray, np.ndarray]:
    """v_pref for every agent and the distance to where it aims.

    Agents head for the goal at the preferred speed, slowing to land on it. With
    ``fields``, agents without a clear straight line to their goal follow the distance
    field instead, aiming at the best cell they can see in a 5 × 5 window.
    """
    to_goal = goal - pos
    dist = np.linalg.norm(to_goal, axis=1)
    direction = np.divide(to_goal, dist[:, None], out=np.zeros_like(to_goal), where=dist[:, None] > 0)
    speed = np.minimum(pref_speed, dist / dt)
    aim = dist.copy()
    if fields is not None:
        clear = np.empty(len(pos), dtype=bool)
        K.line_of_sight(pos, goal, radius, active, prims.circ_c, prims.circ_r, prims.seg_a, prims.seg_b, clear)
        use = active & ~clear
        if use.any():
            fdir = np.zeros_like(pos)
            K.field_directions(pos, field_of, fields.dist, float(fields.origin[0]), float(fields.origin[1]),
                               fields.cell, FIELD_WINDOW, use, radius, prims.circ_c, prims.circ_r, prims.seg_a, prims.seg_b,
                               fdir)
            reach = np.linalg.norm(fdir, axis=1)
            ok = use & (reach > 0)
            direction[ok] = fdir[ok] / reach[ok, None]
            speed[ok] = pref_speed[ok]
            aim[ok] = reach[ok]
    return direction * speed[:, None], aim
