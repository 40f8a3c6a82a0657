"""Obstacles for the swarm: the scene's circles, spheres and boxes as kernel arrays, and
the paper's generated obstacle fields (random or grouped spheres, §2.3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crowdmotion.pso.params import ObstacleField
from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere


@dataclass(frozen=True)
class ObstacleArrays:
    """Round obstacles (centres ``sc`` (M, D), radii ``sr``) and boxes (``bl``, ``bu``)."""

    sc: np.ndarray
    sr: np.ndarray
    bl: np.ndarray
    bu: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> "ObstacleArrays":
        """The scene's obstacles; polygons and moving obstacles are refused by name."""
        d = scene.dim
        sc, sr, bl, bu = [], [], [], []
        for i, ob in enumerate(scene.obstacles):
            if ob.is_moving:
                raise ValueError(f"pso: scene.obstacles.{i} ({type(ob).__name__}) moves; the particle-swarm "
                                 "method supports static obstacles only")
            if isinstance(ob, (Circle, Sphere)):
                sc.append(ob.center)
                sr.append(ob.radius)
            elif isinstance(ob, Box):
                bl.append(ob.lower)
                bu.append(ob.upper)
            elif isinstance(ob, Polygon):
                raise ValueError(f"pso: scene.obstacles.{i} is a polygon; the particle-swarm method supports "
                                 "circle, sphere and box obstacles")
        return cls(np.array(sc, float).reshape(-1, d), np.array(sr, float),
                   np.array(bl, float).reshape(-1, d), np.array(bu, float).reshape(-1, d))

    def grid(self, expand: float, origin: np.ndarray, h: float, dims: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """CSR (start, items) of the obstacles whose bounding box, grown by ``expand``,
        meets each cell of the particles' grid (edge ``h`` from ``origin``, ``dims``
        cells; cell x + dims[0]·(y + dims[1]·z)): a particle within ``expand`` of an
        obstacle finds it in its own cell. Items: j ≥ 0 for sphere j, −j−1 for box j, in
        that order within a cell. Built once per swarm, so numpy rather than a kernel
        that every first run would compile."""
        dims = np.asarray(dims, np.int64)
        lo = np.concatenate([self.sc - self.sr[:, None], self.bl]) - expand
        hi = np.concatenate([self.sc + self.sr[:, None], self.bu]) + expand
        codes = np.concatenate([np.arange(len(self.sr)), -1 - np.arange(len(self.bl))])

        def cell(v):  # each axis's cell, the outermost ones taking everything beyond
            return np.clip(np.trunc((v - origin) / h), 0, dims - 1).astype(np.int64)

        c_lo, c_hi = cell(lo), cell(hi)
        cells, owner = [np.empty(0, np.int64)], [np.empty(0, np.int64)]
        for code, a, b in zip(codes, c_lo, c_hi):
            box = np.meshgrid(*(np.arange(a[k], b[k] + 1) for k in range(len(dims))), indexing="ij")
            flat = np.ravel_multi_index(tuple(box), tuple(dims), order="F").ravel()
            cells.append(flat)
            owner.append(np.full(flat.size, code, np.int64))
        cells, owner = np.concatenate(cells), np.concatenate(owner)
        start = np.zeros(int(np.prod(dims)) + 1, np.int64)
        np.cumsum(np.bincount(cells, minlength=len(start) - 1), out=start[1:])
        return start, owner[np.argsort(cells, kind="stable")]


def obstacle_field(spec: ObstacleField, dim: int, lower, upper, targets, threshold: float,
                   rng: np.random.Generator) -> list:
    """The paper's generated obstacles: ``spec.count`` spheres (circles in 2D) of
    ``spec.radius``, scattered at random or in ``spec.clusters`` clumps over the box
    [lower, upper], each keeping ``spec.clear`` metres of free space round every target."""
    lo = np.asarray(spec.lower if spec.lower is not None else lower, float)[:dim]
    hi = np.asarray(spec.upper if spec.upper is not None else upper, float)[:dim]
    if lo.shape != (dim,) or hi.shape != (dim,) or np.any(hi <= lo):
        raise ValueError(f"pso.obstacle_field: the region lower={lo.tolist()} upper={hi.tolist()} is not a {dim}D box")
    targets = np.asarray(targets, float).reshape(-1, dim)
    clear = spec.clear if spec.clear is not None else spec.radius + threshold + 1.0
    spread = spec.spread if spec.spread is not None else 3.0 * spec.radius

    def free(c):
        return np.all(np.linalg.norm(c[:, None, :] - targets[None], axis=-1) >= spec.radius + clear, axis=1)

    hubs = rng.uniform(lo, hi, size=(spec.clusters, dim))
    centres = np.empty((0, dim))
    for _ in range(200):
        need = spec.count - len(centres)
        if need == 0:
            break
        if spec.layout == "random":
            cand = rng.uniform(lo, hi, size=(4 * need + 8, dim))
        else:
            pick = rng.integers(0, spec.clusters, size=4 * need + 8)
            g = rng.normal(size=(len(pick), dim))
            g *= (spread * rng.uniform(size=(len(pick), 1)) ** (1 / dim)) / np.linalg.norm(g, axis=1, keepdims=True)
            cand = np.clip(hubs[pick] + g, lo, hi)
        centres = np.concatenate([centres, cand[free(cand)][:need]])
    if len(centres) < spec.count:
        raise ValueError(f"pso.obstacle_field: could place only {len(centres)} of {spec.count} obstacles of radius "
                         f"{spec.radius} clear of the targets in lower={lo.tolist()} upper={hi.tolist()}")
    shape = Sphere if dim == 3 else Circle
    return [shape(c, spec.radius) for c in centres]
