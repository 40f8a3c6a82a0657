"""Comfortable motion: the guiding mesh, and with it the walkers on it, changes velocity
no faster than people do (our term, not the paper's: ``FormationParams.mesh_acceleration``
and ``vertex_gap``).

The paper's method is kinematic: every step the mesh is placed anew (attraction, the
field's push, the as-rigid-as-possible solve) and each agent steps onto its vertex. Any
discrete change in what drives the mesh moves the vertices, and the agents with them, by
a different step from one step to the next, and soldiers twitch. Measured in
``formation_army`` (docs/formation.md): the rest shape turning to a mean direction of
travel that jumps whenever one vertex takes its own route round a rock (the whole mesh
shakes about its centre), the paper's handle set changing as vertices enter and leave
the fields (the as-rigid-as-possible solution jumps), and a mesh compressed below the
agents' bodies, whose agents the safety pass then stops and starts (stop and go). So:

* each vertex's velocity changes by at most ``mesh_acceleration`` per second (after the
  deformation, before the speed cap and the pushes out of walls), and in the target area
  a vertex approaches its place no faster than it can stop in;
* vertices nearer each other than two agents' radii and ``vertex_gap`` are pushed apart.

Agents still step onto their vertices (the paper's rule), and the safety passes
(``crowdmotion._contact``) act on those moves afterwards as before: the continuous-time
guarantee of no contact is unchanged.
"""

from __future__ import annotations

import numpy as np

from crowdmotion._contact import build_grid
from crowdmotion.formation._kernels import spread_push

SPREAD_SWEEPS = 3  # pushes apart per step (each resolves half of every pair's shortfall)


def clip_rows(x: np.ndarray, limit) -> np.ndarray:
    """Rows of ``x`` (k, 2) no longer than ``limit`` (a number or (k, 1) array); longer
    rows are scaled down to it."""
    n = np.linalg.norm(x, axis=1, keepdims=True)
    return np.where(n > limit, x * limit / np.maximum(n, 1e-300), x)


def limit_acceleration(last: np.ndarray, want: np.ndarray, acceleration: float, dt: float) -> np.ndarray:
    """Velocities (k, 2) that go from ``last`` toward ``want`` by at most
    ``acceleration`` × ``dt`` (the change keeps its direction)."""
    return last + clip_rows(want - last, acceleration * dt)


def stopping_speed(distance, acceleration: float) -> np.ndarray:
    """The highest speed from which a body braking at ``acceleration`` stops within
    ``distance``: √(2·a·d)."""
    return np.sqrt(2.0 * acceleration * np.asarray(distance, float))


def spread_vertices(vertices: np.ndarray, need: float, sweeps: int = SPREAD_SWEEPS) -> np.ndarray:
    """Vertices (n, 2) nearer each other than ``need`` pushed apart along the line between
    them, each by half the shortfall (Jacobi sweeps over a uniform grid; coincident pairs
    are left as they are). Returns a new array."""
    V = np.array(vertices, float)
    if len(V) < 2:
        return V
    every = np.ones(len(V), dtype=bool)
    push = np.empty_like(V)
    for _ in range(sweeps):
        lo = np.array([V[:, 0].min(), V[:, 1].min()])  # (per column: V.min(axis=0) is 40x slower)
        extent = np.maximum(np.array([V[:, 0].max(), V[:, 1].max()]) - lo, 1e-9)
        h = float(need)
        while np.prod(np.floor(extent / h) + 1) > 2 * len(V) + 16:  # a sparse mesh: fewer, wider cells
            h *= 1.5
        nx, ny = (int(c) for c in np.floor(extent / h) + 1)
        start, items = build_grid(V, every, float(lo[0]), float(lo[1]), h, nx, ny)
        if not spread_push(V, need, start, items, float(lo[0]), float(lo[1]), h, nx, ny, push):
            break
        V += push
    return V
