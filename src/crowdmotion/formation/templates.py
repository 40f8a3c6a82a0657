"""Formation templates: the rest positions of a group's agents in the formation's own
frame (x forward, y to the left), centred on their mean."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from crowdmotion.formation.params import (BlockTemplate, CarsTemplate, CircleTemplate, LineTemplate,
                                          PointsTemplate, TemplateSpec, WedgeTemplate)
from crowdmotion.geometry import finite_array


@dataclass(frozen=True)
class Template:
    """Rest positions ``points`` (n, 2), centred; ``pairs`` (m, 2) agent index pairs that
    form one vehicle (cars), else empty."""

    points: np.ndarray
    kind: str = "points"
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    @property
    def count(self) -> int:
        return len(self.points)

    def placed(self, center, heading: float) -> np.ndarray:
        """The template's points turned by ``heading`` (radians) and moved to ``center``."""
        c, s = np.cos(heading), np.sin(heading)
        return np.asarray(center, float)[:2] + self.points @ np.array([[c, s], [-s, c]])


def _centred(p: np.ndarray) -> np.ndarray:
    return p - p.mean(axis=0)


def block(rows: int, cols: int, spacing: float = 1.0) -> Template:
    """``rows`` ranks (one behind the other along x) of ``cols`` files (across, along y)."""
    x, y = np.meshgrid(-np.arange(rows) * spacing, np.arange(cols) * spacing, indexing="ij")
    return Template(_centred(np.stack([x.ravel(), y.ravel()], axis=1)), "block")


def wedge(rows: int, spacing: float = 1.0) -> Template:
    """An arrow head pointing along +x: row k (k = 0 at the tip) holds 2k + 1 agents."""
    pts = [(-k * spacing, j * spacing) for k in range(rows) for j in range(-k, k + 1)]
    return Template(_centred(np.array(pts, float)), "wedge")


def circle(count: int, radius: float) -> Template:
    """``count`` agents evenly spaced on a circle."""
    a = 2 * np.pi * np.arange(count) / count
    return Template(np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1), "circle")


def line(count: int, spacing: float = 1.0) -> Template:
    """``count`` agents abreast (along y), facing +x; collinear: its mesh is a chain."""
    return Template(_centred(np.stack([np.zeros(count), np.arange(count) * spacing], axis=1)), "line")


def cars(lanes: int, per_lane: int, car_width: float = 1.8, car_gap: float = 6.0,
         lane_width: float = 3.5) -> Template:
    """Cars in ``lanes`` lanes, ``per_lane`` one behind the other ``car_gap`` apart; each
    car is two agents ``car_width`` apart across the lane (agents 2k and 2k + 1)."""
    if car_width >= lane_width:
        raise ValueError(f"car_width {car_width} must be below lane_width {lane_width}")
    pts = []
    for lane in range(lanes):
        for k in range(per_lane):
            for side in (-0.5, 0.5):
                pts.append((-k * car_gap, lane * lane_width + side * car_width))
    pairs = np.arange(2 * lanes * per_lane).reshape(-1, 2)
    return Template(_centred(np.array(pts, float)), "cars", pairs)


def points(pts) -> Template:
    """Any point set (n, 2) in the formation's frame."""
    p = finite_array(pts, "template points")
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ValueError(f"template points must be a non-empty list of 2D points, got shape {p.shape}")
    return Template(_centred(p), "points")


def from_spec(spec: TemplateSpec | Template | dict) -> Template:
    """The Template a ``formation`` table describes (a spec model, or its dict form such
    as ``{"kind": "block", "rows": 10, "cols": 10}``, validated)."""
    if isinstance(spec, Template):
        return spec
    if isinstance(spec, dict):
        from pydantic import TypeAdapter, ValidationError

        from crowdmotion._validation import error_lines

        try:
            spec = TypeAdapter(TemplateSpec).validate_python(spec)
        except ValidationError as exc:
            raise ValueError("formation template: " + "; ".join(error_lines(exc))) from None
    if isinstance(spec, BlockTemplate):
        return block(spec.rows, spec.cols, spec.spacing)
    if isinstance(spec, WedgeTemplate):
        return wedge(spec.rows, spec.spacing)
    if isinstance(spec, CircleTemplate):
        return circle(spec.count, spec.radius)
    if isinstance(spec, LineTemplate):
        return line(spec.count, spec.spacing)
    if isinstance(spec, CarsTemplate):
        return cars(spec.lanes, spec.per_lane, spec.car_width, spec.car_gap, spec.lane_width)
    if isinstance(spec, PointsTemplate):
        return points(spec.points)
    raise ValueError(f"not a formation template: {spec!r}")
