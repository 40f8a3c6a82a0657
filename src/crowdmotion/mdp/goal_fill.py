"""Goals that fill: slots round a shared goal point and a fill order inside goal areas.

The paper's goal cells are absorbing with value 0 (§1.2), so an agent stops on the first
goal cell it reaches: a goal area fills from its rim and the agents behind find the rim
taken. Two documented rules (docs/mdp.md, "Goals that fill") fix that without touching
the values outside the goal:

* **Fill order inside a goal area.** Every goal cell gets a *depth*: its 8/26-connected
  path distance, inside the goal area, from the area's entry (the goal cells next to a
  free cell outside it). Algorithm 3 follows ``v(s) + depth(s)``; an agent on a goal cell
  stays put (absorbing) unless a free goal neighbour lies deeper, so agents walk into the
  free space of the area and the entry stays open for the next.
* **Slots round a shared goal point.** A point goal shared by ``n`` agents (fewer points
  than agents, no despawning) becomes the ``n`` free cells nearest the point(s) along the
  grid: a disc of slots that grows with the group. Depth there is closeness to the point,
  so the slots fill from the point outwards.
"""

from __future__ import annotations

import numpy as np

from crowdmotion.mdp.solvers import exact_values


def nearest_cells(occupancy: np.ndarray, seeds: np.ndarray, count: int, corner_cutting: bool) -> np.ndarray:
    """The ``count`` free cells nearest the ``seeds`` cells by path distance, nearest first.

    Raises ValueError when fewer than ``count`` cells can reach a seed.
    """
    seeds = np.asarray(seeds, dtype=np.int64)
    v = exact_values(occupancy, [tuple(c) for c in seeds], corner_cutting)
    flat = v.ravel()
    reach = np.flatnonzero(np.isfinite(flat))
    if len(reach) < count:
        raise ValueError(f"only {len(reach)} free cells can reach the goal point, {count} agents need one each")
    order = reach[np.argsort(-flat[reach], kind="stable")][:count]
    return np.stack(np.unravel_index(order, occupancy.shape), axis=1)


def fill_depth(occupancy: np.ndarray, goal_cells: np.ndarray, corner_cutting: bool,
               toward: np.ndarray | None = None) -> np.ndarray:
    """Depth of each goal cell (0 elsewhere), in cells; larger = fill earlier.

    With ``toward`` (seed cells, e.g. a shared goal point) depth is closeness to the seeds
    inside the goal cells; otherwise it is the distance from the area's entry cells (goal
    cells with a free non-goal neighbour). Goal cells the rule cannot reach get 0.
    """
    goal = np.zeros(occupancy.shape, dtype=bool)
    goal[tuple(np.asarray(goal_cells).T)] = True
    goal &= occupancy == 0
    inside = np.where(goal, 0, 1).astype(np.uint8)  # only the goal area is walkable
    if toward is not None:
        seeds = [tuple(c) for c in np.asarray(toward) if goal[tuple(c)]]
    else:
        outside = (occupancy == 0) & ~goal
        near_outside = np.zeros_like(goal)
        padded = np.pad(outside, 1)
        for off in np.ndindex(*(3,) * goal.ndim):
            near_outside |= padded[tuple(slice(o, o + s) for o, s in zip(off, goal.shape))]
        seeds = [tuple(c) for c in np.argwhere(goal & near_outside)]
    depth = np.zeros(occupancy.shape)
    if not seeds:
        return depth
    d = -exact_values(inside, seeds, corner_cutting)
    reach = goal & np.isfinite(d)
    if toward is not None:  # closeness to the point: the point itself is the deepest
        d = d.max(initial=0.0, where=reach) + 1.0 - d
    return np.where(reach, d, 0.0)
