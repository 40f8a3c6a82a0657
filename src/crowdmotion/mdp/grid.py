"""Occupancy grids for the MDP (paper §1.2): rasterise a Scene, or take a grid as given."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from crowdmotion.scene import Scene

SQRT2 = float(np.sqrt(2.0))

# bytes per cell the fast solver and Algorithm 3 need (values, distances, occupancy, ...)
BYTES_PER_CELL = 40


def min_cell_size(radius: float) -> float:
    """Smallest allowed cell edge: the paper needs cell > sqrt(2) x the agent's diameter."""
    return SQRT2 * 2.0 * radius


def max_radius(cell_size: float) -> float:
    """Largest agent radius a cell allows, just under cell / (2 sqrt 2)."""
    return cell_size / (2.0 * SQRT2) * (1.0 - 1e-6)


@dataclass
class GridMap:
    """An occupancy grid placed in the world: cell (0, .., 0) has its lower corner at ``origin``.

    ``occupancy`` is uint8, 1 = obstacle, 0 = free (the paper's ``grid``).
    """

    occupancy: np.ndarray
    cell_size: float
    origin: np.ndarray

    @property
    def shape(self) -> tuple[int, ...]:
        return self.occupancy.shape

    @property
    def dim(self) -> int:
        return self.occupancy.ndim

    def centers(self, cells) -> np.ndarray:
        """World coordinates of cell centres; ``cells`` is (..., D) integer indices."""
        return self.origin + (np.asarray(cells, dtype=float) + 0.5) * self.cell_size

    def cell_of(self, points) -> np.ndarray:
        """Integer cell index of each world point, (..., D); may lie outside the grid."""
        return np.floor((np.asarray(points, dtype=float) - self.origin) / self.cell_size).astype(np.int64)

    def in_grid(self, cells) -> np.ndarray:
        c = np.asarray(cells)
        return np.all((c >= 0) & (c < np.array(self.shape)), axis=-1)

    def all_centers(self) -> np.ndarray:
        """(cells..., D) centres of every cell."""
        idx = np.indices(self.shape).transpose(*range(1, self.dim + 1), 0)
        return self.centers(idx)


class GridTooLarge(ValueError, MemoryError):
    """A grid that would not fit in memory: a mistake in the scenario (ValueError) as
    much as a lack of memory."""


def check_grid_size(shape: tuple[float, ...], cell_size: float | None = None) -> None:
    """Refuse a grid that would not fit in memory, before allocating it: one rastered
    from a scene (``cell_size`` given) or one handed to the solvers as an array."""
    with np.errstate(over="ignore"):  # inf for absurd shapes, and no overflow
        need = float(np.prod([float(s) + 4 for s in shape])) * BYTES_PER_CELL
    try:
        avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        avail = 16 * 2**30
    if need > avail:
        dims = " x ".join(f"{s:.3g}" for s in shape)
        if cell_size is None:  # an array handed to the solvers
            raise GridTooLarge(f"a grid of {dims} cells needs about {need / 2**30:.3g} GiB to solve, but only "
                               f"{avail / 2**30:.1f} GiB is free: solve a coarser grid")
        raise GridTooLarge(f"a grid of {cell_size:.3g} m cells over this scene has {dims} cells and needs about "
                           f"{need / 2**30:.3g} GiB, but only {avail / 2**30:.1f} GiB is free: use a larger "
                           f"mdp.cell_size, or smaller scene.bounds")


def rasterise(scene: Scene, cell_size: float, t: float | None = 0.0, moving: bool = True) -> GridMap:
    """Mark every cell that any obstacle overlaps (or that sticks out of the bounds) as 1.

    Conservative: a cell is free only if no obstacle touches its interior, so an agent
    whose centre stays in free cells (and, with corner cutting off, moves diagonally
    only past free cells) never overlaps an obstacle. Moving obstacles are placed at
    time ``t``; ``moving=False`` leaves them out.
    """
    if not (np.isfinite(cell_size) and cell_size > 0):
        raise ValueError(f"cell_size must be a positive number of metres, got {cell_size!r}")
    extent = scene.upper - scene.lower
    cells = np.maximum(np.floor(extent / cell_size + 1e-9), 1)
    check_grid_size(tuple(float(n) for n in cells), float(cell_size))
    shape = tuple(int(n) for n in cells)
    grid = GridMap(np.zeros(shape, dtype=np.uint8), float(cell_size), scene.lower.copy())
    for ob in scene.obstacles:
        if ob.is_moving and not moving:
            continue
        mark_obstacle(grid, ob, 0.0 if t is None else t)
    return grid


def mark_obstacle(grid: GridMap, ob, t: float) -> None:
    """Set to 1 the cells the obstacle (placed at time ``t``) overlaps, in place."""
    shift = ob.offset(t)
    lo, hi = ob.bounds()
    c_lo = np.maximum(grid.cell_of(lo + shift), 0)
    c_hi = np.minimum(grid.cell_of(hi + shift), np.array(grid.shape) - 1)
    if np.any(c_hi < c_lo):
        return
    idx = np.indices(tuple(c_hi - c_lo + 1)).reshape(grid.dim, -1).T + c_lo
    cell_lo = grid.origin + idx * grid.cell_size - shift
    # shrink by a hair so that cells merely touching an obstacle's boundary stay free
    eps = 1e-9 * grid.cell_size
    hit = ob.intersects_boxes(cell_lo + eps, cell_lo + grid.cell_size - eps)
    grid.occupancy[tuple(idx[hit].T)] = 1


def load_grid(path: str | Path) -> np.ndarray:
    """Read an occupancy grid from ``.npy``, ``.csv``/``.txt`` (0/1 values) or an image.

    Images: dark pixels (< 50 % grey) are obstacles; row 0 is the top of the picture, so
    the array is flipped to make axis 1 point up.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no grid file at {path}")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        arr = np.load(path, allow_pickle=False)
    elif suffix in (".csv", ".txt"):
        arr = np.loadtxt(path, delimiter="," if suffix == ".csv" else None)
    elif suffix in (".png", ".jpg", ".jpeg", ".bmp", ".gif"):
        import matplotlib.image as mpimg

        img = np.asarray(mpimg.imread(path), dtype=float)
        if img.ndim == 3:
            img = img[..., :3].mean(axis=-1)
        if img.max() > 1.0:
            img = img / 255.0
        arr = (img < 0.5)[::-1].T
    else:
        raise ValueError(f"unknown grid format {suffix!r} for {path}; use .npy, .csv, .txt or an image")
    return validate_grid(arr)


def validate_grid(grid) -> np.ndarray:
    """``grid`` as a uint8 array of 0/1 with 2 or 3 axes, or a ValueError saying what is wrong."""
    arr = np.asarray(grid)
    if arr.ndim not in (2, 3):
        raise ValueError(f"grid must have 2 or 3 axes, got shape {arr.shape}")
    if min(arr.shape) < 1:
        raise ValueError(f"grid must not be empty, got shape {arr.shape}")
    check_grid_size(arr.shape)  # before reading the cells: a grid too large to solve is refused at once
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number):
            raise ValueError(f"grid must hold numbers 0 (free) and 1 (obstacle), got dtype {arr.dtype}")
        if np.issubdtype(arr.dtype, np.integer):
            ok = arr.min() >= 0 and arr.max() <= 1
        else:
            ok = bool(np.all((arr == 0) | (arr == 1)))
        if not ok:
            bad = arr[(arr != 0) & (arr != 1)][:3]
            raise ValueError(f"grid must hold only 0 (free) and 1 (obstacle), found {bad}")
    return np.ascontiguousarray(arr, dtype=np.uint8)
