"""Groups of agents: how many, where they spawn, where they go, and their body/speed."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence, Union

import numpy as np

from crowdmotion.geometry import as_points, finite_array, positive_number


class Region:
    """An area (2D) or volume (3D) that agents spawn in or head for."""

    dim: int

    @property
    def center(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def contains(self, points) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def nearest(self, points) -> np.ndarray:  # pragma: no cover - overridden
        """(N, D) the point of the region nearest each of ``points``."""
        raise NotImplementedError

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:  # pragma: no cover
        """``count`` points drawn uniformly inside the region, shape (count, dim)."""
        raise NotImplementedError


class Points(Region):
    """An explicit list of positions, one per agent (spawn) or candidate goals."""

    def __init__(self, points):
        p = finite_array(points, "Points.points")
        if p.ndim != 2 or p.shape[1] not in (2, 3) or len(p) == 0:
            raise ValueError(f"Points.points must be a non-empty list of 2D or 3D points, got shape {p.shape}")
        self.points = p
        self.dim = p.shape[1]

    @property
    def center(self):
        return self.points.mean(axis=0)

    def contains(self, points):
        p = as_points(points, self.dim)
        return np.any(np.all(np.isclose(p[..., None, :], self.points), axis=-1), axis=-1)

    def sample(self, count, rng):
        if count > len(self.points):
            raise ValueError(f"Points holds {len(self.points)} positions but {count} agents need one each")
        return self.points[:count].copy()

    def nearest(self, points):
        p = np.asarray(points, dtype=float)
        d = np.linalg.norm(p[:, None, :] - self.points[None], axis=-1)
        return self.points[np.argmin(d, axis=1)]

    def __repr__(self):
        return f"Points({self.points.tolist()})"


class Rect(Region):
    """Axis-aligned rectangle (2D) or box (3D): ``Rect(lower, upper)``."""

    def __init__(self, lower: Sequence[float], upper: Sequence[float]):
        lo = finite_array(lower, "Rect.lower").ravel()
        hi = finite_array(upper, "Rect.upper").ravel()
        if lo.shape != hi.shape or lo.size not in (2, 3):
            raise ValueError(f"Rect corners must both have 2 or 3 coordinates, got {lo.tolist()}, {hi.tolist()}")
        if np.any(hi < lo):
            raise ValueError(f"Rect.upper must not be below Rect.lower, got lower={lo.tolist()} upper={hi.tolist()}")
        self.lower, self.upper, self.dim = lo, hi, lo.size

    @property
    def center(self):
        return (self.lower + self.upper) / 2

    def contains(self, points):
        p = as_points(points, self.dim)
        return np.all((p >= self.lower) & (p <= self.upper), axis=-1)

    def sample(self, count, rng):
        return rng.uniform(self.lower, self.upper, size=(count, self.dim))

    def nearest(self, points):
        return np.clip(np.asarray(points, dtype=float), self.lower, self.upper)

    def __repr__(self):
        return f"Rect({self.lower.tolist()}, {self.upper.tolist()})"


class Lattice(Rect):
    """Spawn only: a rectangle filled evenly on a triangular lattice (2D): ``Lattice(lower,
    upper)``. The agents stand in rows, each row shifted by half a spacing, with the
    widest spacing at which the group's count fits (clear of obstacles, the scene's
    bounds and bodies already placed): a dense block start, as the FZJ experiments
    begin, up to the closest packing of bodies ``spawn_gap`` apart (about 3.8 persons/m²
    at radius 0.25 m and the default gap; a rect's random draws stop near 2)."""

    def __init__(self, lower: Sequence[float], upper: Sequence[float]):
        super().__init__(lower, upper)
        if self.dim != 2:
            raise ValueError(f"Lattice corners must have 2 coordinates (a lattice spawn is 2D), got "
                             f"{self.lower.tolist()}, {self.upper.tolist()}")

    def sites(self, spacing: float, phase: Sequence[float] | None = None, within=None) -> np.ndarray:
        """(m, 2) the lattice's sites at ``spacing`` metres inside the rectangle, or inside
        ``within`` (lower, upper) when given (the part of it where bodies fit, say): rows
        ``spacing`` · √3/2 apart, alternate rows shifted by half a spacing. ``phase``
        (fx, fy in [0, 1)): the first site sits fx spacings and fy row pairs in from the
        lower corner; None: the lattice is centred."""
        lower, upper = (self.lower, self.upper) if within is None else (np.asarray(within[0], float),
                                                                      np.asarray(within[1], float))
        size = upper - lower
        dy = spacing * np.sqrt(3.0) / 2.0
        if phase is None:  # centred: as much room left at either side and at top and bottom
            ox0 = 0.5 * (size[0] - np.floor(size[0] / spacing + 1e-9) * spacing)
            oy0 = 0.5 * (size[1] - np.floor(size[1] / dy + 1e-9) * dy)
        else:
            ox0, oy0 = float(phase[0]) * spacing, (float(phase[1]) * 2.0 * dy) % (2.0 * dy)
        rows = int(np.floor((size[1] - oy0) / dy + 1e-9)) + 1 if size[1] >= oy0 else 0
        out = []
        for k in range(rows):
            ox = (ox0 + (0.5 * spacing if k % 2 else 0.0)) % spacing
            cols = int(np.floor((size[0] - ox) / spacing + 1e-9)) + 1 if size[0] >= ox else 0
            if cols > 0:
                x = lower[0] + ox + spacing * np.arange(cols)
                out.append(np.stack([x, np.full(cols, lower[1] + oy0 + k * dy)], axis=1))
        return np.concatenate(out) if out else np.empty((0, 2))

    def __repr__(self):
        return f"Lattice({self.lower.tolist()}, {self.upper.tolist()})"


class Disc(Region):
    """Disc (2D) or ball (3D): ``Disc(center, radius)``."""

    def __init__(self, center: Sequence[float], radius: float):
        c = finite_array(center, "Disc.center").ravel()
        if c.size not in (2, 3):
            raise ValueError(f"Disc.center must have 2 or 3 coordinates, got {c.tolist()}")
        r = float(radius)
        if not np.isfinite(r) or r <= 0:
            raise ValueError(f"Disc.radius must be a positive number, got {radius!r}")
        self._center, self.radius, self.dim = c, r, c.size

    @property
    def center(self):
        return self._center

    def contains(self, points):
        p = as_points(points, self.dim)
        return np.linalg.norm(p - self._center, axis=-1) <= self.radius

    def sample(self, count, rng):
        d = rng.normal(size=(count, self.dim))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        r = self.radius * rng.uniform(size=(count, 1)) ** (1.0 / self.dim)
        return self._center + d * r

    def nearest(self, points):
        off = np.asarray(points, dtype=float) - self._center
        d = np.linalg.norm(off, axis=-1, keepdims=True)
        return self._center + off * np.minimum(1.0, self.radius / np.maximum(d, 1e-300))

    def __repr__(self):
        return f"Disc({self._center.tolist()}, {self.radius})"


class MovingTarget:
    """A goal that moves: keyframes ``(times, positions)`` linearly interpolated."""

    def __init__(self, times, positions):
        t = finite_array(times, "MovingTarget.times").ravel()
        p = finite_array(positions, "MovingTarget.positions")
        if p.ndim != 2 or p.shape[0] != t.size or p.shape[1] not in (2, 3):
            raise ValueError(f"MovingTarget.positions must have shape ({t.size}, 2 or 3), got {p.shape}")
        if t.size == 0 or np.any(np.diff(t) <= 0):
            raise ValueError(f"MovingTarget.times must be non-empty and increasing, got {t.tolist()}")
        self.times, self.positions, self.dim = t, p, p.shape[1]

    @property
    def center(self):
        return self.positions[-1]

    def at(self, t):
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self.times, self.positions[:, k]) for k in range(self.dim)], axis=-1)


Goal = Union[Rect, Disc, Points, MovingTarget]


def describe_region(region) -> str:
    """A spawn/goal region as the scenario file writes it (``rect [0, 4]-[1, 6]``)."""
    def fmt(v) -> str:
        return "[" + ", ".join(f"{x:g}" for x in np.asarray(v, float).ravel()) + "]"

    if isinstance(region, Lattice):
        return f"lattice {fmt(region.lower)}-{fmt(region.upper)}"
    if isinstance(region, Rect):
        return f"rect {fmt(region.lower)}-{fmt(region.upper)}"
    if isinstance(region, Disc):
        return f"disc centre {fmt(region.center)} radius {region.radius:g}"
    if isinstance(region, Points):
        return f"point {fmt(region.points[0])}" if len(region.points) == 1 else f"{len(region.points)} points"
    if isinstance(region, MovingTarget):
        return f"moving target ({len(region.times)} keyframes)"
    return repr(region)


def as_region(value, what: str) -> Region | MovingTarget:
    """A Region (or MovingTarget) from a Region, or from a bare point (a one-point Region)."""
    if isinstance(value, (Region, MovingTarget)):
        return value
    p = finite_array(value, what).ravel()
    if p.size not in (2, 3):
        several = np.ndim(value) == 2 and np.shape(value)[1] in (2, 3)
        raise ValueError(f"{what} must be a point with 2 or 3 coordinates or a region, got {value!r}"
                         + ("; for several points, Points([...])" if several else ""))
    return Points(p[None, :])


@dataclass
class Group:
    """A named set of agents with a spawn region, a goal and per-agent body/speed.

    Parameters
    ----------
    name : str            group name, used in outputs and reports
    count : int           number of agents
    spawn : Region        where agents start (Points, Rect, Lattice, Disc) or a point
    goal : Region         where they go (Rect, Disc, Points, a point, or MovingTarget)
    radius : float        body radius in metres (bounding circle/sphere)
    max_speed : float     metres per second
    pref_speed : float    preferred walking speed, metres per second
    attributes : dict     method-specific extras (personality, formation template, ...)
    """

    name: str
    count: int
    spawn: Any
    goal: Any
    radius: float = 0.25
    max_speed: float = 1.5
    pref_speed: float = 1.3
    attributes: dict = field(default_factory=dict)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Group.name must be a non-empty string, got {self.name!r}")
        where = f"Group {self.name!r}"
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) or self.count <= 0:
            raise ValueError(f"{where}: count must be a positive integer, got {self.count!r}")
        self.count = int(self.count)
        for attr in ("radius", "max_speed", "pref_speed"):
            setattr(self, attr, positive_number(getattr(self, attr), f"{where}: {attr}"))
        if self.pref_speed > self.max_speed:
            raise ValueError(f"{where}: pref_speed {self.pref_speed} exceeds max_speed {self.max_speed}")
        self.spawn = as_region(self.spawn, f"{where}: spawn")
        self.goal = as_region(self.goal, f"{where}: goal")
        if isinstance(self.spawn, MovingTarget):
            raise ValueError(f"{where}: spawn cannot be a moving target")
        if isinstance(self.goal, Lattice):
            raise ValueError(f"{where}: a lattice is a spawn region, not a goal: give the goal as a Rect")
        if self.spawn.dim != self.goal.dim:
            raise ValueError(f"{where}: spawn is {self.spawn.dim}D but goal is {self.goal.dim}D")

    @property
    def dim(self) -> int:
        return self.spawn.dim
