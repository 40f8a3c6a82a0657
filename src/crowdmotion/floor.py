"""The walkable floor of a 2D scene as a raster: inside the bounds, outside the static
obstacles. Two measures read it: RVO's density-aware speed (``rvo.density.FloorShare``,
the share of a Gaussian kernel on the floor) and the report's local density
(:class:`DiscFloor`, the walkable area of the disc round a point, ``metrics.group_report``).
"""

from __future__ import annotations

import numpy as np
from scipy import fft
from scipy.ndimage import map_coordinates

from crowdmotion.scene import Scene

CELL_M = 0.2           # raster of the walkable floor
MAX_CELLS = 1_000_000  # a larger scene gets coarser cells
KERNEL_SUBSAMPLES = 8  # per cell side, for the share of each cell inside a disc


class WalkableFloor:
    """The floor of ``scene`` (2D) on square cells of ``cell`` metres (coarser where the
    bounds would need more than ``max_cells``), from the bounds' lower corner on:

    - ``blocked``: (nx, ny) bool, the cell's centre lies in a static obstacle (on its edge
      counts as in);
    - ``cover``: (nx, ny) float, the share of the cell that is walkable floor: outside the
      obstacles (from the signed distance of its centre to them, ½ + d / cell clipped to
      0-1: exact for a straight edge along a raster axis, close for others) and inside the
      bounds (the last row and column may reach past them).
    """

    def __init__(self, scene: Scene, cell: float = CELL_M, max_cells: int = MAX_CELLS):
        if scene.dim != 2:
            raise ValueError(f"the walkable floor is measured in 2D scenes, this one is {scene.dim}D")
        lo, hi = scene.lower, scene.upper
        self.cell = max(float(cell), float(np.sqrt(float(np.prod(hi - lo)) / max_cells)))
        shape = np.maximum(np.ceil((hi - lo) / self.cell).astype(np.int64), 1)
        self.origin = lo
        xs = lo[0] + (np.arange(shape[0]) + 0.5) * self.cell
        ys = lo[1] + (np.arange(shape[1]) + 0.5) * self.cell
        self.blocked = np.zeros(tuple(shape), dtype=bool)
        self.cover = np.ones(tuple(shape), dtype=float)
        for ob in scene.static_obstacles:  # each over the cells of its bounding box (and one more) only
            olo, ohi = (np.asarray(b, dtype=float)[:2] for b in ob.bounds())
            i0 = np.maximum(np.floor((olo - lo) / self.cell - 0.5).astype(np.int64), 0)
            i1 = np.minimum(np.ceil((ohi - lo) / self.cell - 0.5).astype(np.int64), shape - 1)
            if np.any(i1 < i0):
                continue
            cx, cy = xs[i0[0]:i1[0] + 1], ys[i0[1]:i1[1] + 1]
            centres = np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1).reshape(-1, 2)
            d = ob.signed_distance(centres).reshape(len(cx), len(cy))
            window = (slice(i0[0], i1[0] + 1), slice(i0[1], i1[1] + 1))
            self.blocked[window] |= d <= 0
            np.minimum(self.cover[window], np.clip(0.5 + d / self.cell, 0.0, 1.0), out=self.cover[window])
        # the share of the last row and column inside the bounds
        for axis in (0, 1):
            over = float(shape[axis] * self.cell - (hi[axis] - lo[axis]))
            if over > 0:
                edge = [slice(None), slice(None)]
                edge[axis] = -1
                self.cover[tuple(edge)] *= max(0.0, 1.0 - over / self.cell)


def disc_kernel(radius: float, cell: float, subsamples: int = KERNEL_SUBSAMPLES) -> np.ndarray:
    """The share of each cell of a square raster of side ``cell`` that a disc of
    ``radius`` centred on the middle cell's centre covers (its sum times cell² is about
    π · radius²)."""
    n = int(np.ceil(radius / cell - 0.5))  # cells either side of the middle one
    sub = (np.arange(subsamples) + 0.5) / subsamples - 0.5  # sample offsets within a cell
    axis = (np.arange(-n, n + 1)[:, None] + sub[None, :]).ravel() * cell
    inside = (axis[:, None] ** 2 + axis[None, :] ** 2) <= radius * radius
    return inside.reshape(2 * n + 1, subsamples, 2 * n + 1, subsamples).mean(axis=(1, 3))


def _convolve_same(a: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``a`` convolved with an odd-sized ``kernel`` (zero beyond ``a``), the shape of ``a``:
    by FFT, as scipy.signal.fftconvolve(mode="same") but without importing scipy.signal."""
    full = np.array(a.shape) + np.array(kernel.shape) - 1
    shape = [fft.next_fast_len(int(d), real=True) for d in full]
    out = fft.irfft2(fft.rfft2(a, shape) * fft.rfft2(kernel, shape), shape)
    h = np.array(kernel.shape) // 2
    return out[h[0]:h[0] + a.shape[0], h[1]:h[1] + a.shape[1]]


class DiscFloor:
    """The walkable area (m²) of the disc of ``radius`` metres round any point of
    ``scene``: the part inside the bounds and outside the static obstacles, as the
    walkable floor's raster (:class:`WalkableFloor`) convolved with the disc; between cell
    centres it is interpolated linearly (within 1 % of the exact area, at most 3 % of
    the disc's, on 0.2 m cells and a 2 m disc). π · radius² in the open; about half of it with
    the centre on a long wall."""

    def __init__(self, scene: Scene, radius: float, cell: float = CELL_M, max_cells: int = MAX_CELLS):
        floor = WalkableFloor(scene, cell, max_cells)
        self.radius = float(radius)
        self.cell = floor.cell
        self.origin = floor.origin - self.cell  # a ring of cells beyond the bounds, so that a point on their
        cover = np.pad(floor.cover, 1)           # edge reads between the cells either side of it
        kernel = disc_kernel(self.radius, self.cell)
        full = np.pi * self.radius**2
        # the kernel's sum is π r² within the subsampling: scaled to it exactly, the open floor reads π r²
        self.area = np.clip(_convolve_same(cover, kernel * (full / kernel.sum())), 0.0, full)

    def at(self, points: np.ndarray) -> np.ndarray:
        """(N,) the walkable area of the disc round each of ``points`` (N, 2), m² (0
        beyond the raster)."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        idx = ((p - self.origin) / self.cell - 0.5).T  # fractional cell index of each point
        return map_coordinates(self.area, idx, order=1, mode="nearest") * np.all(
            (idx > -1.0) & (idx < np.array(self.area.shape)[:, None]), axis=0)
