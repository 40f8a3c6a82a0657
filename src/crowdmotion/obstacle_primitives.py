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
        self._static_cache = None
        self.any_moving = any(ob.is_moving for ob in scene.obstacles)

    def at(self, t: float, dt: float) -> ObstaclePrimitives:
        """Primitives placed at time t, each moving at its mean velocity over [t, t + dt]."""
        if not self.any_moving and self._static_cache is not None:
            return self._static_cache
        cc, cr, cv = [], [], []
        for ob in self.circles:
            o0, o1 = ob.offset(t), ob.offset(t + dt)
            cc.append(ob.center + o0)
            cr.append(ob.radius)
            cv.append((o1 - o0) / dt)
        sa, sb, sv = [], [], []
        for ob, segs in self.outlined:
            o0, o1 = (np.zeros(2), np.zeros(2)) if ob is None else (ob.offset(t), ob.offset(t + dt))
            sa.append(segs[:, 0] + o0)
            sb.append(segs[:, 1] + o0)
            sv.append(np.broadcast_to((o1 - o0) / dt, (len(segs), 2)))
        prim = ObstaclePrimitives(
            np.array(cc, dtype=float).reshape(-1, 2), np.array(cr, dtype=float).reshape(-1),
            np.array(cv, dtype=float).reshape(-1, 2),
            np.concatenate(sa).astype(float) if sa else np.zeros((0, 2)),
            np.concatenate(sb).astype(float) if sb else np.zeros((0, 2)),
            np.concatenate(sv).astype(float) if sv else np.zeros((0, 2)),
        )
        if not self.any_moving:
            self._static_cache = prim
        return prim
