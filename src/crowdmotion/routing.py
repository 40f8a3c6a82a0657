"""Routes round walls for every method: exact 8-connected distance fields to goal regions
on a grid over the scene (corner cutting off), and walking down them.

RVO aims its preferred velocities along them; formations move their guiding mesh along
them, vertex by vertex, so a formation follows a corridor round its corners.

The exact fields come from :func:`crowdmotion.mdp.solvers.exact_values` (scipy's
Dijkstra on small grids, nothing to compile; the numba bucket solver on large ones).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from crowdmotion.groups import MovingTarget, Points
from crowdmotion.mdp.solvers import SCIPY_MAX_CELLS, exact_values_each, move_graph
from crowdmotion.scene import Scene

MAX_FIELD_CELLS = 16_000_000
PASSAGE_SAMPLES = 8  # a side: the points of a cell where a body is tried in a narrow passage
PASSAGE_MARGIN = 3  # cells round a narrow passage within which the floor on its sides must stay apart


@dataclass
class DistanceFields:
    """Metres to each goal region along free space, on one grid: (F, nx, ny), inf = blocked."""

    dist: np.ndarray
    origin: np.ndarray
    cell: float
    blocked: np.ndarray | None = None  # (nx, ny) cells a body does not fit in
    goal_cells: list | None = None     # per field, (K, 2) goal cells

    @cached_property
    def passage_points(self) -> np.ndarray:
        """:func:`passage_samples` of this grid's cell, made once."""
        return passage_samples(self.cell)

    @cached_property
    def move_graph(self):
        """The moves between the free cells (corner cutting off) that scipy's Dijkstra
        walks for a new field on this grid, built once (None on grids the numba solver
        takes, or without ``blocked``)."""
        if self.blocked is None or self.blocked.size > SCIPY_MAX_CELLS:
            return None
        return move_graph(self.blocked.astype(np.uint8), corner_cutting=False)

    def cells(self, points: np.ndarray) -> np.ndarray:
        """(P, 2) the grid cell index of each point, off the grid (negative or past its
        size) for a point outside it."""
        return np.floor((np.asarray(points) - self.origin) / self.cell).astype(np.int64)

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """(P, 2) the grid cell holding each point; for a point off the grid, the edge cell
        nearest it."""
        return np.clip(self.cells(points), 0, np.array(self.dist.shape[1:]) - 1)

    def at(self, field, points: np.ndarray) -> np.ndarray:
        """Field values at the cells holding ``points`` (inf outside the grid); ``field``
        one field's index, or one per point."""
        idx = self.cells(points)
        inside = np.all((idx >= 0) & (idx < np.array(self.dist.shape[1:])), axis=1)
        out = np.full(len(idx), np.inf)
        out[inside] = self.dist[np.broadcast_to(field, len(idx))[inside], idx[inside, 0], idx[inside, 1]]
        return out


    def nearby(self, field: int, points: np.ndarray, window: int = 2) -> np.ndarray:
        """Metres to field ``field``'s goal from each point: the least of its value plus the
        straight way to it over the cells within ``window`` cells (a point by a wall, whose
        own cell a body does not fit in, reads its free neighbours); inf where none has one."""
        shape = np.array(self.dist.shape[1:])
        pts = np.asarray(points, float).reshape(-1, 2)
        idx = self.cells(pts)
        out = np.full(len(idx), np.inf)
        for dx in range(-window, window + 1):
            for dy in range(-window, window + 1):
                c = idx + [dx, dy]
                inside = np.all((c >= 0) & (c < shape), axis=1)
                d = np.full(len(idx), np.inf)
                d[inside] = self.dist[field, c[inside, 0], c[inside, 1]]
                centre = self.origin + (c + 0.5) * self.cell
                out = np.minimum(out, d + np.linalg.norm(centre - pts, axis=1))
        return out

    def reachable(self, field_of: np.ndarray, points: np.ndarray, window: int = 2) -> np.ndarray:
        """Whether some cell within ``window`` cells of each point has a finite distance
        to the point's goal (field ``field_of``)."""
        shape = np.array(self.dist.shape[1:])
        idx = self.cells(points)
        out = np.zeros(len(idx), dtype=bool)
        for dx in range(-window, window + 1):
            for dy in range(-window, window + 1):
                c = idx + [dx, dy]
                inside = np.all((c >= 0) & (c < shape), axis=1)
                ok = np.zeros(len(idx), dtype=bool)
                ok[inside] = np.isfinite(self.dist[field_of[inside], c[inside, 0], c[inside, 1]])
                out |= ok
        return out

    def descent_path(self, field: int, points: np.ndarray, steps: int) -> np.ndarray:
        """(m, steps + 1, 2): the centres of the cells met walking ``steps`` cells down
        field ``field`` from each point, one cell at a time to the least-valued of the 8
        around (the point itself first, and all along where it has no finite value; the
        last cell repeated once the goal is reached)."""
        shape = np.array(self.dist.shape[1:])
        d = self.dist[field]
        padded = np.pad(d, 1, constant_values=np.inf)
        idx = self.cells(points)
        ok = np.all((idx >= 0) & (idx < shape), axis=1)
        ok[ok] &= np.isfinite(d[idx[ok, 0], idx[ok, 1]])
        moves = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if a or b])
        out = np.repeat(np.asarray(points, float)[:, None], steps + 1, axis=1)
        c = idx[ok]
        for s in range(1, steps + 1):
            around = padded[c[:, 0, None] + 1 + moves[None, :, 0], c[:, 1, None] + 1 + moves[None, :, 1]]
            best = np.argmin(around, axis=1)
            better = around[np.arange(len(c)), best] < padded[c[:, 0] + 1, c[:, 1] + 1]
            c[better] += moves[best[better]]
            out[ok, s] = self.origin + (c + 0.5) * self.cell
        return out


def default_cell(scene: Scene, radius: float) -> float:
    """Field cell edge: the agent radius, coarsened so the grid stays under 4M cells."""
    extent = scene.upper - scene.lower
    return float(max(radius, np.sqrt(np.prod(extent) / 4e6)))


def passage_samples(cell: float) -> np.ndarray:
    """(PASSAGE_SAMPLES², 2) offsets from a cell's centre of the points spread over it where
    a body is tried in a narrow passage (:func:`narrow_passages`), nearest the centre
    first (rvo guidance aims at the first of them an agent can reach)."""
    k = PASSAGE_SAMPLES
    off = ((np.arange(k) + 0.5) / k - 0.5) * cell
    pts = np.stack(np.meshgrid(off, off, indexing="ij"), axis=-1).reshape(-1, 2)
    return np.ascontiguousarray(pts[np.argsort(np.einsum("ij,ij->i", pts, pts), kind="stable")])


def narrow_passages(scene: Scene, centres: np.ndarray, clearance: np.ndarray, blocked: np.ndarray,
                    radius: float, cell: float) -> np.ndarray:
    """(shape) the blocked cells of a passage that a body fits through but whose cell
    centres all lie within ``radius`` of its walls: a door between 2 radii and 2 radii plus
    a cell wide (a 0.5 m door, bodies of radius 0.2 m on 0.2 m cells) showed closed, and a
    crowd whose only way out it was could not be sent there.

    A blocked cell is open to a body where one of ``PASSAGE_SAMPLES``² points spread over
    it is ``radius`` clear of the obstacles (clearance is 1-Lipschitz, so only cells whose
    centre is within half a diagonal of that need trying). Of those cells, the ones opened
    are the groups (joined across faces) that join two parts of the floor the free cells
    leave apart within ``PASSAGE_MARGIN`` cells round the group: a door is one whether or
    not there is a longer way round (a door of 1.2 m in a corridor open at its ends, bodies
    of radius 0.5 m on 0.5 m cells, was left shut and walkers went 65 m round the corridor
    instead of 25 m through it); the others, a strip along a wall that leads nowhere new,
    stay blocked, so fields that need no such passage are unchanged."""
    from scipy import ndimage

    maybe = blocked.ravel() & (clearance >= radius - cell * np.sqrt(2) / 2)
    opened = np.zeros(blocked.shape, dtype=bool)
    if not maybe.any():
        return opened
    grid = passage_samples(cell)
    rows = np.flatnonzero(maybe)
    pts = (centres[rows][:, None, :] + grid[None]).reshape(-1, 2)
    fits = np.zeros(blocked.size, dtype=bool)
    fits[rows] = (scene.static_obstacle_distance(pts) >= radius).reshape(len(rows), -1).any(axis=1)
    fits = fits.reshape(blocked.shape)
    if not fits.any():
        return opened
    strips, n = ndimage.label(fits)
    joining = []
    for s, box in enumerate(ndimage.find_objects(strips), start=1):
        # the floor in a window PASSAGE_MARGIN cells round the group: the parts its free
        # cells fall into there, and the ones the group touches across a face
        win = tuple(slice(max(b.start - PASSAGE_MARGIN, 0), b.stop + PASSAGE_MARGIN) for b in box)
        floor, parts = ndimage.label(~blocked[win])
        if parts < 2:
            continue
        touch = ndimage.binary_dilation(strips[win] == s) & (floor > 0)
        if len(np.unique(floor[touch])) >= 2:
            joining.append(s)
    return np.isin(strips, joining) if joining else opened


def _cell_centres(scene: Scene, cell: float, shape: tuple) -> np.ndarray:
    """(nx·ny, 2) the centres of a field grid's cells, row by row."""
    return scene.lower + (np.indices(shape).reshape(2, -1).T + 0.5) * cell


def blocked_cells(scene: Scene, radius: float, cell: float | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """(cell edge, (nx·ny, 2) cell centres, (nx, ny) blocked) of the grid
    :func:`distance_fields` solves on: a cell is blocked when its centre lies within
    ``radius`` of a static obstacle, unless it is part of a narrow passage a body fits
    through (:func:`narrow_passages`)."""
    cell = default_cell(scene, radius) if cell is None else float(cell)
    if not (np.isfinite(cell) and cell > 0):
        raise ValueError(f"rvo.field_cell must be a positive number of metres, got {cell!r}")
    extent = scene.upper - scene.lower
    shape = tuple(int(n) for n in np.maximum(np.ceil(extent / cell - 1e-9), 1))
    if np.prod(shape) > MAX_FIELD_CELLS:
        raise ValueError(f"rvo.field_cell {cell} m gives a {shape} grid; use a larger cell")
    centres = _cell_centres(scene, cell, shape)
    clearance = scene.static_obstacle_distance(centres)
    blocked = (clearance < radius).reshape(shape)
    blocked &= ~narrow_passages(scene, centres, clearance, blocked, radius, cell)
    return cell, centres, blocked


def distance_fields(scene: Scene, goals: list, radius: float, cell: float | None = None,
                    names: list[str] | None = None, like: DistanceFields | None = None) -> DistanceFields:
    """Exact 8-connected distances (corner cutting off) to each goal region, in metres.

    A cell is blocked when its centre lies within ``radius`` of a static obstacle, so the
    field routes agents' centres where their bodies fit, unless it is part of a narrow
    passage a body fits through (:func:`blocked_cells`). Goals are regions (their free
    cells) or Points (the cells of the points). ``names``: what an error calls each goal
    (default ``groups.K``, a scenario's group). ``like``: fields solved before for the same
    obstacles and radius, whose grid (cell, blocked cells and moves graph,
    :attr:`DistanceFields.move_graph`) the new ones are solved on, not found again (the
    most of a new field's cost in a large scene).
    """
    if like is None:
        cell, centres, blocked = blocked_cells(scene, radius, cell)
        graph = None
    else:
        cell, blocked, graph = like.cell, like.blocked, like.move_graph
        centres = _cell_centres(scene, cell, blocked.shape)
    shape = blocked.shape
    goal_cells = []
    for k, goal in enumerate(goals):
        label = names[k] if names else f"groups.{k}"
        if isinstance(goal, MovingTarget):
            raise ValueError(f"{label}: field guidance needs a fixed goal, not a moving target")
        if isinstance(goal, Points):
            gi = np.floor((goal.points - scene.lower) / cell).astype(np.int64)
            gi = np.clip(gi, 0, np.array(shape) - 1)
            cells = [tuple(c) for c in gi if not blocked[tuple(c)]]
        else:
            inside = goal.contains(centres).reshape(shape) & ~blocked
            cells = [tuple(c) for c in np.argwhere(inside)]
        if not cells:
            raise ValueError(f"{label}: the goal {goal!r} has no cell free of obstacles "
                             f"(field cell {cell:.3f} m, agent radius {radius} m)")
        goal_cells.append(np.array(sorted(set(cells)), dtype=np.int64))
    values = exact_values_each(blocked.astype(np.uint8), [[tuple(c) for c in cells] for cells in goal_cells],
                               corner_cutting=False, graph=graph)
    dist = -np.stack(values) * cell if values else np.zeros((0,) + shape)
    return DistanceFields(dist, scene.lower.astype(float).copy(), cell, blocked, goal_cells)
