"""The scene every method shares: bounds and static or keyframed moving obstacles."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np
import shapely

from crowdmotion.geometry import as_points, finite_array


@dataclass(frozen=True)
class KeyframePath:
    """Keyframed motion of an obstacle's centre, linearly interpolated.

    Before the first key time the obstacle sits at the first position, after the last
    at the last.
    """

    times: np.ndarray
    positions: np.ndarray

    @classmethod
    def build(cls, path, dim: int, where: str) -> "KeyframePath":
        if len(path) != 2:
            raise ValueError(f"{where}.path must be (times, positions), got {path!r}")
        times = finite_array(path[0], f"{where}.path.times").ravel()
        pos = finite_array(path[1], f"{where}.path.positions")
        if pos.ndim != 2 or pos.shape != (len(times), dim):
            raise ValueError(
                f"{where}.path.positions must have shape ({len(times)}, {dim}), got {pos.shape}"
            )
        if len(times) == 0 or np.any(np.diff(times) <= 0):
            raise ValueError(f"{where}.path.times must be non-empty and increasing, got {times.tolist()}")
        return cls(times, pos)

    def at(self, t: float | np.ndarray) -> np.ndarray:
        """Centre position at time(s) ``t``: shape (D,) or (len(t), D)."""
        t = np.asarray(t, dtype=float)
        cols = [np.interp(t, self.times, self.positions[:, k]) for k in range(self.positions.shape[1])]
        return np.stack(cols, axis=-1)


class Obstacle:
    """Base class of obstacle shapes. ``path`` makes the shape move (see KeyframePath);
    ``present`` is the time window [start, end) during which it stands (always, unless a
    stepping simulator added or removed it while running: see :meth:`during`)."""

    path: KeyframePath | None = None
    dim: int = 0
    present: tuple[float, float] = (-np.inf, np.inf)

    @property
    def is_timed(self) -> bool:
        """Whether the obstacle stands for part of the time only."""
        return self.present != (-np.inf, np.inf)

    def present_at(self, t: float | np.ndarray) -> np.ndarray:
        """Whether the obstacle stands at time(s) ``t`` (start <= t < end)."""
        t = np.asarray(t, dtype=float)
        return (t >= self.present[0]) & (t < self.present[1])

    def during(self, start: float = -np.inf, end: float = np.inf) -> "Obstacle":
        """A copy of the obstacle that stands from ``start`` until ``end`` (seconds; an
        empty window, end = start, is an obstacle taken out as soon as it was put in)."""
        start, end = float(start), float(end)
        if np.isnan(start) or np.isnan(end) or end < start:
            raise ValueError(f"an obstacle's time window must be start <= end, got [{start}, {end})")
        twin = copy.copy(self)
        twin.present = (start, end)
        return twin

    @property
    def center(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def is_moving(self) -> bool:
        return self.path is not None

    def offset(self, t: float | np.ndarray) -> np.ndarray:
        """Translation of the shape at time(s) ``t`` relative to its rest position."""
        if self.path is None:
            t = np.asarray(t, dtype=float)
            return np.zeros(t.shape + (self.dim,))
        return self.path.at(t) - self.center

    def _init_path(self, path, where: str) -> None:
        self.path = None if path is None else KeyframePath.build(path, self.dim, where)

    # subclasses implement, for the shape at rest:
    def signed_distance(self, points: np.ndarray) -> np.ndarray:  # pragma: no cover
        """Distance from each point to the surface, negative inside."""
        raise NotImplementedError

    def intersects_boxes(self, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:  # pragma: no cover
        """Whether the shape overlaps each axis-aligned box (lower[i], upper[i])."""
        raise NotImplementedError

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
        """Axis-aligned bounding box of the shape at rest."""
        raise NotImplementedError


class _Round(Obstacle):
    """Circle (2D) or sphere (3D)."""

    _dim = 2

    def __init__(self, center: Sequence[float], radius: float, path=None):
        name = type(self).__name__
        c = finite_array(center, f"{name}.center").ravel()
        if c.shape != (self._dim,):
            raise ValueError(f"{name}.center must have {self._dim} coordinates, got {c.tolist()}")
        r = float(radius)
        if not np.isfinite(r) or r <= 0:
            raise ValueError(f"{name}.radius must be a positive number, got {radius!r}")
        self.dim = self._dim
        self._center = c
        self.radius = r
        self._init_path(path, name)

    @property
    def center(self) -> np.ndarray:
        return self._center

    def signed_distance(self, points):
        p = as_points(points, self.dim)
        return np.linalg.norm(p - self._center, axis=-1) - self.radius

    def intersects_boxes(self, lower, upper):
        nearest = np.clip(self._center, lower, upper)
        return np.sum((nearest - self._center) ** 2, axis=-1) <= self.radius**2

    def bounds(self):
        return self._center - self.radius, self._center + self.radius

    def __repr__(self) -> str:
        return f"{type(self).__name__}(center={self._center.tolist()}, radius={self.radius})"


class Circle(_Round):
    """A disc obstacle in a 2D scene: ``Circle(center, radius, path=None)``."""

    _dim = 2


class Sphere(_Round):
    """A ball obstacle in a 3D scene: ``Sphere(center, radius, path=None)``."""

    _dim = 3


def box_signed_distance(offset: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside) of points ``offset`` from the centre of an
    axis-aligned box of half-sizes ``half``; both broadcast, the last axis the coordinates."""
    q = np.abs(offset) - half
    return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)


class Box(Obstacle):
    """An axis-aligned box obstacle, 2D or 3D: ``Box(lower, upper, path=None)``."""

    def __init__(self, lower: Sequence[float], upper: Sequence[float], path=None):
        lo = finite_array(lower, "Box.lower").ravel()
        hi = finite_array(upper, "Box.upper").ravel()
        if lo.shape != hi.shape or lo.size not in (2, 3):
            raise ValueError(f"Box.lower and Box.upper must both have 2 or 3 coordinates, got {lo.tolist()}, "
                             f"{hi.tolist()}")
        if np.any(hi <= lo):
            raise ValueError(f"Box.upper must exceed Box.lower on every axis, got lower={lo.tolist()} "
                             f"upper={hi.tolist()}")
        self.dim = lo.size
        self.lower = lo
        self.upper = hi
        self._init_path(path, "Box")

    @property
    def center(self) -> np.ndarray:
        return (self.lower + self.upper) / 2

    def signed_distance(self, points):
        p = as_points(points, self.dim)
        return box_signed_distance(p - self.center, (self.upper - self.lower) / 2)

    def intersects_boxes(self, lower, upper):
        return np.all((np.asarray(lower) <= self.upper) & (np.asarray(upper) >= self.lower), axis=-1)

    def bounds(self):
        return self.lower.copy(), self.upper.copy()

    def __repr__(self) -> str:
        return f"Box(lower={self.lower.tolist()}, upper={self.upper.tolist()})"


class Polygon(Obstacle):
    """A simple 2D polygon obstacle (shapely geometry): ``Polygon(vertices, path=None)``."""

    def __init__(self, vertices, path=None):
        if isinstance(vertices, shapely.Polygon):
            geom = vertices
        else:
            v = finite_array(vertices, "Polygon.vertices")
            if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
                raise ValueError(f"Polygon.vertices must be at least three (x, y) pairs, got shape {v.shape}")
            geom = shapely.Polygon(v)
        if not geom.is_valid or geom.area <= 0:
            raise ValueError(f"Polygon.vertices do not form a valid simple polygon: {shapely.is_valid_reason(geom)}")
        shapely.prepare(geom)
        self.dim = 2
        self.geometry = geom
        self._init_path(path, "Polygon")

    @property
    def center(self) -> np.ndarray:
        c = self.geometry.centroid
        return np.array([c.x, c.y])

    @property
    def vertices(self) -> np.ndarray:
        return np.asarray(self.geometry.exterior.coords)[:-1]

    def signed_distance(self, points):
        p = as_points(points, 2)
        d = shapely.distance(self.geometry.exterior, shapely.points(p))
        inside = shapely.contains_xy(self.geometry, p[..., 0], p[..., 1])
        return np.where(inside, -d, d)

    def intersects_boxes(self, lower, upper):
        lower = np.asarray(lower, dtype=float)
        upper = np.asarray(upper, dtype=float)
        boxes = shapely.box(lower[..., 0], lower[..., 1], upper[..., 0], upper[..., 1])
        return shapely.intersects(self.geometry, boxes)

    def bounds(self):
        b = self.geometry.bounds
        return np.array(b[:2]), np.array(b[2:])

    def __repr__(self) -> str:
        return f"Polygon(vertices={self.vertices.tolist()})"


ObstacleShape = Union[Circle, Sphere, Box, Polygon]


SHAPES_AT_ONCE = 1 << 18  # point-obstacle pairs measured in one array (static_obstacle_distance)


class Scene:
    """Axis-aligned bounds in 2D or 3D plus obstacles.

    ``Scene(bounds=(lower_corner, upper_corner), obstacles=[Circle(...), Box(...)])``.
    Units are metres; times are seconds.
    """

    def __init__(self, bounds, obstacles: Sequence[Obstacle] = ()):
        if len(bounds) != 2:
            raise ValueError(f"Scene.bounds must be (lower_corner, upper_corner), got {bounds!r}")
        lo = finite_array(bounds[0], "Scene.bounds.lower").ravel()
        hi = finite_array(bounds[1], "Scene.bounds.upper").ravel()
        if lo.shape != hi.shape or lo.size not in (2, 3):
            raise ValueError(f"Scene.bounds corners must both have 2 or 3 coordinates, got {lo.tolist()}, "
                             f"{hi.tolist()}")
        if np.any(hi <= lo):
            raise ValueError(f"Scene.bounds upper corner must exceed the lower on every axis, got {lo.tolist()}, "
                             f"{hi.tolist()}")
        self.lower = lo
        self.upper = hi
        self.obstacles: list[Obstacle] = list(obstacles)
        self._shapes = None  # the static boxes and discs as arrays (static_obstacle_distance)
        for i, ob in enumerate(self.obstacles):
            if not isinstance(ob, Obstacle):
                raise TypeError(f"Scene.obstacles[{i}] must be a Circle, Sphere, Box or Polygon, got {ob!r}")
            if ob.dim != self.dim:
                raise ValueError(
                    f"Scene.obstacles[{i}] ({type(ob).__name__}) is {ob.dim}D but the scene is {self.dim}D"
                )

    @property
    def dim(self) -> int:
        return int(self.lower.size)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.lower, self.upper

    @property
    def static_obstacles(self) -> list[Obstacle]:
        """Obstacles that neither move nor come and go."""
        return [o for o in self.obstacles if not o.is_moving and not o.is_timed]

    @property
    def moving_obstacles(self) -> list[Obstacle]:
        return [o for o in self.obstacles if o.is_moving]

    def at_time(self, t: float) -> "Scene":
        """The scene as it stands at time ``t``: the obstacles present then, each for good."""
        return Scene((self.lower, self.upper), [o if not o.is_timed else o.during() for o in self.obstacles
                                                if not o.is_timed or o.present_at(t)])

    def contains(self, points) -> np.ndarray:
        """Whether each point lies inside the bounds."""
        p = as_points(points, self.dim)
        return np.all((p >= self.lower) & (p <= self.upper), axis=-1)

    def obstacle_distance(self, points, t: float = 0.0) -> np.ndarray:
        """Signed distance from each point to the nearest obstacle at time ``t``."""
        p = as_points(points, self.dim)
        d = self.static_obstacle_distance(p)
        for ob in self.obstacles:
            if (ob.is_moving or ob.is_timed) and ob.present_at(t):
                d = np.minimum(d, ob.signed_distance(p - ob.offset(t)))
        return d

    def static_obstacle_distance(self, points) -> np.ndarray:
        """Signed distance from each point to the nearest obstacle that does not move
        (boxes and discs or balls measured all at once, as arrays)."""
        p = as_points(points, self.dim)
        d = np.full(p.shape[:-1], np.inf)
        statics = self.static_obstacles
        cached = self._shapes  # rebuilt when the list of obstacles changes (the same objects, kept)
        if cached is None or len(cached[0]) != len(statics) or any(a is not b for a, b in zip(cached[0], statics)):
            boxes = [ob for ob in statics if isinstance(ob, Box)]
            rounds = [ob for ob in statics if isinstance(ob, _Round)]
            stack = lambda rows: np.array(rows, dtype=float).reshape(-1, self.dim)  # noqa: E731
            self._shapes = (statics, stack([b.center for b in boxes]), stack([(b.upper - b.lower) / 2 for b in boxes]),
                            stack([r.center for r in rounds]), np.array([r.radius for r in rounds], dtype=float),
                            [ob for ob in statics if not isinstance(ob, (Box, _Round))])
        _, box_c, box_half, round_c, round_r, others = self._shapes
        flat, out = p.reshape(-1, self.dim), d.reshape(-1)
        step = max(1, SHAPES_AT_ONCE // max(1, len(box_c) + len(round_c)))
        for s in range(0, len(flat), step):  # the shapes' own sums, a block of points at a time
            q = flat[s:s + step, None, :]
            if len(box_c):
                out[s:s + step] = np.minimum(out[s:s + step], box_signed_distance(q - box_c, box_half).min(axis=1))
            if len(round_c):
                out[s:s + step] = np.minimum(out[s:s + step],
                                             (np.linalg.norm(q - round_c, axis=-1) - round_r).min(axis=1))
        for ob in others:
            d = np.minimum(d, ob.signed_distance(p))
        return d

    def clearance(self, points) -> np.ndarray:
        """Distance from each point to the nearest static obstacle or the scene's walls
        (its bounds): the room a body standing there has."""
        p = as_points(points, self.dim)
        return np.minimum(self.wall_clearance(p), self.static_obstacle_distance(p))

    def wall_clearance(self, points: np.ndarray) -> np.ndarray:
        """Distance from each point (..., dim) to the nearest side of the scene's bounds
        (negative outside them)."""
        return np.minimum(points - self.lower, self.upper - points).min(axis=-1)

    def to_dict(self) -> dict:
        """Plain description for metadata and plots (JSON-serialisable)."""
        obs = []
        for ob in self.obstacles:
            if isinstance(ob, _Round):
                d = {"shape": type(ob).__name__.lower(), "center": ob.center.tolist(), "radius": ob.radius}
            elif isinstance(ob, Box):
                d = {"shape": "box", "lower": ob.lower.tolist(), "upper": ob.upper.tolist()}
            else:
                d = {"shape": "polygon", "vertices": ob.vertices.tolist()}
            if ob.path is not None:
                d["path"] = {"times": ob.path.times.tolist(), "positions": ob.path.positions.tolist()}
            if ob.is_timed:  # JSON has no infinity: an open end is null
                d["present"] = [float(x) if np.isfinite(x) else None for x in ob.present]
            obs.append(d)
        return {"bounds": [self.lower.tolist(), self.upper.tolist()], "obstacles": obs}

    @classmethod
    def from_dict(cls, data: dict) -> "Scene":
        """Inverse of :meth:`to_dict`."""
        obs = []
        for d in data.get("obstacles", []):
            path = d.get("path")
            path = None if path is None else (path["times"], path["positions"])
            shape = d["shape"]
            if shape == "circle":
                obs.append(Circle(d["center"], d["radius"], path=path))
            elif shape == "sphere":
                obs.append(Sphere(d["center"], d["radius"], path=path))
            elif shape == "box":
                obs.append(Box(d["lower"], d["upper"], path=path))
            elif shape == "polygon":
                obs.append(Polygon(d["vertices"], path=path))
            else:
                raise ValueError(f"unknown obstacle shape {shape!r}")
            if d.get("present") is not None:
                lo, hi = d["present"]
                obs[-1] = obs[-1].during(-np.inf if lo is None else lo, np.inf if hi is None else hi)
        return cls(bounds=data["bounds"], obstacles=obs)

    def __repr__(self) -> str:
        return f"Scene(bounds=({self.lower.tolist()}, {self.upper.tolist()}), obstacles={self.obstacles!r})"


def scene_of(traj) -> Scene | None:
    """The scene stored with trajectories (their ``metadata["scene"]``), if any."""
    data = traj.metadata.get("scene")
    return Scene.from_dict(data) if data else None
