"""Scene obstacles as the 2D contact kernels see them: discs and wall segments with a
velocity (used by the RVO and guiding-mesh formation methods)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crowdmotion.scene import Box, Circle, Obstacle, Polygon, Scene


@dataclass(frozen=True)
class ObstaclePrimitives:
    """Discs (centre, radius, velocity) and segments (a, b, velocity) at one moment."""

    circ_c: np.ndarray
    circ_r: np.ndarray
    circ_v: np.ndarray
    seg_a: np.ndarray
    seg_b: np.ndarray
    seg_v: np.ndarray

    def with_discs(self, centres: np.ndarray, radii: np.ndarray, velocities: np.ndarray) -> ObstaclePrimitives:
        """These primitives and more discs (centre, radius, velocity per step), after the
        others: agents a caller moves itself, for the ones the crowd steers."""
        return ObstaclePrimitives(np.concatenate([self.circ_c, centres]), np.concatenate([self.circ_r, radii]),
                                  np.concatenate([self.circ_v, velocities]), self.seg_a, self.seg_b, self.seg_v)


def outline_segments(ob: Obstacle) -> np.ndarray:
    """(k, 2, 2) boundary segments of a box or polygon in its rest frame."""
    if isinstance(ob, Box):
        (x0, y0), (x1, y1) = ob.lower, ob.upper
        v = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    elif isinstance(ob, Polygon):
        v = ob.vertices
    else:  # pragma: no cover - guarded by check_supported
        raise TypeError(f"no outline for {ob!r}")
    return np.stack([v, np.roll(v, -1, axis=0)], axis=1)


def check_supported(scene: Scene, method: str = "rvo", what: str = "the RVO method") -> None:
    """The 2D methods say so plainly for a 3D scene."""
    if scene.dim != 2:
        raise ValueError(f"{method}: {what} simulates 2D scenes (walking crowds); this scene is 3D")


class ObstacleSet:
    """The scene's obstacles, ready to be placed at any time with their step velocity.

    The scene's bounds are walls too: the four sides of the bounding rectangle are
    static segments, so agents stay inside the scene.
    """

    def __init__(self, scene: Scene, method: str = "rvo", what: str = "the RVO method"):
        check_supported(scene, method, what)
        self.circles = [ob for ob in scene.obstacles if isinstance(ob, Circle)]
        self.outlined = [(ob, outline_segments(ob)) for ob in scene.obstacles if not isinstance(ob, Circle)]
        self.outlined.append((None, outline_segments(Box(scene.lower, scene.upper))))
        self._first_segment = np.cumsum([0] + [len(segs) for _, segs in self.outlined])[:-1]
        self._moving_circles = [i for i, ob in enumerate(self.circles) if ob.is_moving]
        self._moving_outlined = [i for i, (ob, _) in enumerate(self.outlined) if ob is not None and ob.is_moving]
        self._static_cache = None  # every obstacle placed at the first call (all of them if none moves)
        self.any_moving = any(ob.is_moving for ob in scene.obstacles)

    def at(self, t: float, dt: float) -> ObstaclePrimitives:
        """Primitives placed at time t, each moving at its mean velocity over [t, t + dt]."""
        if not self.any_moving and self._static_cache is not None:
            return self._static_cache
        if self._static_cache is None:  # every obstacle placed once; later only the moving ones
            self._static_cache = self._place(t, dt, range(len(self.circles)), range(len(self.outlined)))
            if not self.any_moving:
                return self._static_cache
        return self._place(t, dt, self._moving_circles, self._moving_outlined, self._static_cache)

    def _place(self, t: float, dt: float, circles, outlined, base: ObstaclePrimitives | None = None):
        """Primitives at time t: the listed circles and outlined shapes placed anew, the
        others as in ``base`` (every one placed when ``base`` is None)."""
        if base is None:
            n_seg = sum(len(segs) for _, segs in self.outlined)
            base = ObstaclePrimitives(np.zeros((len(self.circles), 2)), np.zeros(len(self.circles)),
                                      np.zeros((len(self.circles), 2)), np.zeros((n_seg, 2)), np.zeros((n_seg, 2)),
                                      np.zeros((n_seg, 2)))
        prim = ObstaclePrimitives(*(a.copy() for a in (base.circ_c, base.circ_r, base.circ_v, base.seg_a, base.seg_b,
                                                       base.seg_v)))
        for i in circles:
            ob = self.circles[i]
            o0, o1 = ob.offset(t), ob.offset(t + dt)
            prim.circ_c[i] = ob.center + o0
            prim.circ_r[i] = ob.radius
            prim.circ_v[i] = (o1 - o0) / dt
        for i in outlined:
            ob, segs = self.outlined[i]
            o0, o1 = (np.zeros(2), np.zeros(2)) if ob is None else (ob.offset(t), ob.offset(t + dt))
            at = slice(self._first_segment[i], self._first_segment[i] + len(segs))
            prim.seg_a[at] = segs[:, 0] + o0
            prim.seg_b[at] = segs[:, 1] + o0
            prim.seg_v[at] = (o1 - o0) / dt
        return prim
