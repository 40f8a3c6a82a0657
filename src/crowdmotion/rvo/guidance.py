"""Global guidance for RVO: preferred velocities straight at the goal or along an exact
distance field (:mod:`crowdmotion.routing`) when obstacles stand between."""

from __future__ import annotations

import numpy as np

from crowdmotion.geometry import row_norms
from crowdmotion.obstacle_primitives import ObstaclePrimitives
from crowdmotion.routing import DistanceFields, passage_samples
from crowdmotion.rvo import _kernels as K

FIELD_REACH_M = 0.45  # agents aim about this far along the field ...
FIELD_WINDOW_MIN = 2  # ... and at least this many cells each way
FIELD_END_M = 1.0  # an agent this near its field's end with its goal out of sight is lost on it


def field_window(cell: float) -> int:
    """Cells each way of the window an agent aims within along a field of ``cell`` metres:
    about FIELD_REACH_M, at least FIELD_WINDOW_MIN cells (2 cells from 0.18 m on, 3 on
    the 0.15 m cells of bodies of radius 0.15 m). Two cells of 0.15 m reach only 0.3 m:
    the aim then follows each cell's rounding and every re-solve of the congestion-aware
    field, and swings by up to 100° from one step to the next; beside a wall it turned
    into the wall, and a walker pressed there crept along it (RiMEA 15's last person out
    of the corner, docs/rvo.md)."""
    return max(FIELD_WINDOW_MIN, int(round(FIELD_REACH_M / cell)))


def preferred_velocities(pos, goal, pref_speed, active, dt, fields: DistanceFields | None, field_of,
                         prims: ObstaclePrimitives, radius,
                         lost: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """v_pref for every agent and the distance to where it aims.

    Agents head for the goal at the preferred speed, slowing to land on it. With
    ``fields``, agents without a clear straight line to their goal follow the distance
    field instead, aiming at the best cell they can see in a window reaching about
    FIELD_REACH_M each way (:func:`field_window`). ``lost`` (N,), if given, is set True
    for the agents that need the field and have come to its end (within ``FIELD_END_M``)
    or find no better cell in it: on a field shared with other goals, at another's goal
    with their own out of sight.
    """
    to_goal = goal - pos
    dist = row_norms(to_goal)
    direction = np.divide(to_goal, dist[:, None], out=np.zeros_like(to_goal), where=dist[:, None] > 0)
    speed = np.minimum(pref_speed, dist / dt)
    aim = dist.copy()
    if fields is not None:
        clear = np.empty(len(pos), dtype=bool)
        K.line_of_sight(pos, goal, radius, active, prims.circ_c, prims.circ_r, prims.seg_a, prims.seg_b, clear)
        use = active & ~clear
        if use.any():
            fdir = np.zeros_like(pos)
            K.field_directions(pos, field_of, fields.dist, float(fields.origin[0]), float(fields.origin[1]),
                               fields.cell, field_window(fields.cell), use, radius, prims.circ_c, prims.circ_r,
                               prims.seg_a, prims.seg_b, fields.passage_points, fdir)
            reach = row_norms(fdir)
            ok = use & (reach > 0)
            if lost is not None:
                lost[:] = use & (~ok | (fields.at(field_of, pos) <= FIELD_END_M))
            direction[ok] = fdir[ok] / reach[ok, None]
            speed[ok] = pref_speed[ok]
            aim[ok] = reach[ok]
    return direction * speed[:, None], aim
