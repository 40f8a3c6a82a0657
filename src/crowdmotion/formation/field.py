"""The obstacle potential field (§3.1, eq. 2) on a uniform grid over the scene.

Each obstacle spreads a field of range r round itself: at a cell centre x at distance d
from its surface the magnitude is f = 1 − d/r for 0 < d < r (1 inside the obstacle, 0 from
r on) and the direction is (x − c)/‖x − c‖, away from the obstacle's centre c (the paper's
choice: it adds a tangential push round wide obstacles); for a box, c is the nearest point
of its core, the box shrunk by r on every side (the centre of a box up to 2r across; beside
a long wall the push is square to it, see ``_core_point``). Fields of several obstacles add
as vectors; ``strength`` keeps the largest magnitude, which decides whether a vertex is
"in a field". Static obstacles are painted once; moving ones are repainted every step
over the cells they touch only (their old and new footprints).
"""

from __future__ import annotations

import numpy as np

from crowdmotion.obstacle_primitives import check_supported
from crowdmotion.scene import Box, Obstacle, Scene


def radial_field(points: np.ndarray, center: np.ndarray, distance: np.ndarray, reach: float):
    """Eq. (2) at ``points`` (k, 2) for one obstacle: (f·direction (k, 2), f (k,))."""
    f = np.where(distance <= 0, 1.0, np.clip(1.0 - distance / reach, 0.0, 1.0))
    away = points - center
    norm = np.linalg.norm(away, axis=1, keepdims=True)
    direction = np.divide(away, norm, out=np.zeros_like(away), where=norm > 0)
    return f[:, None] * direction, f


def disc_field(points: np.ndarray, centers: np.ndarray, radii: np.ndarray, reach: float):
    """Eq. (2) at ``points`` (k, 2) from discs (centres (m, 2), radii (m,)), summed."""
    vec = np.zeros((len(points), 2))
    f = np.zeros(len(points))
    for c, r in zip(centers, radii):
        d = np.linalg.norm(points - c, axis=1) - r
        v, fi = radial_field(points, c, d, reach)
        vec += v
        f = np.maximum(f, fi)
    return vec, f


def _core_point(ob: Obstacle, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, reach: float) -> np.ndarray:
    """The point of an obstacle's core that the field at ``x`` (k, 2) points away from: a
    disc's (or polygon's) centre, as the paper has it; for a box the nearest point of the
    box shrunk by the field's range on every side (at most to its middle). A box no
    larger than twice the range has its centre as its core, as before; a long wall's core
    is a segment, so beside it the push is square to the wall. (Away from a wall's centre,
    a column beside a long wall was pushed along it: in a 2 m corridor built of two large
    boxes the push at the corner pointed back down the corridor, stronger than the
    attraction, and the formation of RiMEA 6 stood at the corner.)"""
    if not isinstance(ob, Box):
        return np.broadcast_to(ob.center[:2], x.shape)
    shrink = np.minimum(reach, 0.5 * (hi - lo))
    return np.clip(x, lo + shrink, hi - shrink)


class PotentialField:
    """The field of a scene's obstacles on a grid of ``cell`` metres; ``reach`` is r. The
    scene's bounds push as walls do (``bounds=False``: the obstacles' field alone)."""

    def __init__(self, scene: Scene, reach: float, cell: float, bounds: bool = True):
        check_supported(scene, "formation", "the guiding-mesh method")
        self.reach, self.cell = float(reach), float(cell)
        self.origin = scene.lower.astype(float)
        cells = np.maximum(np.ceil((scene.upper - scene.lower) / cell), 1)  # floats: no overflow
        if float(np.prod(cells)) > 50_000_000:
            raise ValueError(f"formation: a field grid of {cells[0]:.3g} x {cells[1]:.3g} cells is too large; "
                             f"raise formation.field_cell (now {cell:g} m) or shrink scene.bounds")
        self.shape = tuple(int(n) for n in cells)  # (nx, ny)
        self.static_vec = np.zeros(self.shape + (2,))
        self.static_f = np.zeros(self.shape)
        self.dynamic_vec = np.zeros(self.shape + (2,))
        self.dynamic_f = np.zeros(self.shape)
        self.moving = [ob for ob in scene.obstacles if ob.is_moving]
        self._footprints: list[tuple[slice, slice]] = []
        for ob in scene.obstacles:
            if not ob.is_moving:
                self._paint(ob, np.zeros(2), self.static_vec, self.static_f)
        if bounds:
            self._paint_bounds(scene.lower.astype(float)[:2], scene.upper.astype(float)[:2])
        self.cells_updated = 0

    def _window(self, ob: Obstacle, offset: np.ndarray) -> tuple[slice, slice]:
        lo, hi = ob.bounds()
        lo = (lo[:2] + offset - self.reach - self.origin) / self.cell
        hi = (hi[:2] + offset + self.reach - self.origin) / self.cell
        i0, j0 = np.clip(np.floor(lo).astype(int), 0, self.shape)
        i1, j1 = np.clip(np.ceil(hi).astype(int) + 1, 0, self.shape)
        return slice(i0, i1), slice(j0, j1)

    def _paint(self, ob: Obstacle, offset: np.ndarray, vec: np.ndarray, strength: np.ndarray) -> tuple[slice, slice]:
        si, sj = self._window(ob, offset)
        ii, jj = np.meshgrid(np.arange(si.start, si.stop), np.arange(sj.start, sj.stop), indexing="ij")
        x = self.origin + (np.stack([ii, jj], axis=-1).reshape(-1, 2) + 0.5) * self.cell
        if len(x):
            lo, hi = ob.bounds()
            v, f = radial_field(x, _core_point(ob, x - offset, lo[:2], hi[:2], self.reach) + offset,
                                ob.signed_distance(x - offset), self.reach)
            vec[si, sj] += v.reshape(ii.shape + (2,))
            strength[si, sj] = np.maximum(strength[si, sj], f.reshape(ii.shape))
        return si, sj

    def _paint_bounds(self, lower: np.ndarray, upper: np.ndarray) -> None:
        """The scene's bounds are walls: each side spreads the field of a long box wall
        beside it (f = 1 − d/r at distance d, pointing square into the scene), so a
        corridor whose one side is the bounds is pushed from both sides."""
        centres = self.origin + (np.indices(self.shape).transpose(1, 2, 0) + 0.5) * self.cell
        for axis in range(2):
            for edge, inward in ((lower[axis], 1.0), (upper[axis], -1.0)):
                d = np.abs(centres[..., axis] - edge)
                f = np.clip(1.0 - d / self.reach, 0.0, 1.0)
                self.static_vec[..., axis] += inward * f
                self.static_f[:] = np.maximum(self.static_f, f)

    def update(self, t: float) -> None:
        """Repaint the moving obstacles at time ``t``: their previous cells are cleared and
        the cells they reach now painted; nothing else is touched."""
        if not self.moving:
            return
        for si, sj in self._footprints:
            self.dynamic_vec[si, sj] = 0.0
            self.dynamic_f[si, sj] = 0.0
            self.cells_updated += (si.stop - si.start) * (sj.stop - sj.start)
        self._footprints = [self._paint(ob, ob.offset(t)[:2], self.dynamic_vec, self.dynamic_f) for ob in self.moving]
        self.cells_updated += sum((si.stop - si.start) * (sj.stop - sj.start) for si, sj in self._footprints)

    def sample(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f·direction (k, 2), f (k,)) at ``points``, from the cell each lies in."""
        ij = np.floor((np.asarray(points, float) - self.origin) / self.cell).astype(np.int64)
        ij = np.clip(ij, 0, np.array(self.shape) - 1)
        flat = ij[:, 0] * self.shape[1] + ij[:, 1]
        vec = self.static_vec.reshape(-1, 2)[flat]
        f = self.static_f.ravel()[flat]
        if self.moving:
            vec += self.dynamic_vec.reshape(-1, 2)[flat]
            f = np.maximum(f, self.dynamic_f.ravel()[flat])
        return vec, f
