"""MDP groups on routes: the grid walkers as :class:`crowdmotion.journeys.Journeys` sees them.

An MDP agent follows every stage but ``queue``: ``goto`` and ``leave`` switch it to the
value field of the stage's area (Algorithm 3 then walks it there and fills the area from
its entry, as a group goal does); ``wait`` keeps it where it stands, on a cell of the area
it reached; ``choose`` picks by weights, or the nearest option along the grid's values
(``least_crowded`` weighs the same walking distances); ``leave`` takes the agent out of
the scene once it stands on a cell of the exit. Each area's field is solved once, the
first time an agent is sent there, and kept (:attr:`MDPWalkers.solves` counts them). The
route logic is the shared state machine's; this module only lets it see the grid.
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Disc, Points, Rect
from crowdmotion.mdp.goal_fill import fill_depth
from crowdmotion.mdp.grid import GridMap
from crowdmotion.mdp.params import STAGES, MDPParams
from crowdmotion.mdp.trajectory import Walker
from crowdmotion.stages import refuse_unfollowed


def check_mdp_route(route, where: str) -> None:
    """Refuse a route with a queue stage (grid agents do not queue), naming it."""
    refuse_unfollowed(route, where, STAGES, "an MDP group")


class MDPWalkers:
    """Algorithm 3's agents as :class:`crowdmotion.journeys.Walkers`: positions are cell
    centres, an agent has arrived when it stands on a goal cell of the field it follows,
    and setting a goal switches it to its area's field (solved on first use, then kept).
    Call :meth:`after_step` after each step and before ``journeys.update``: agents bound
    for an exit that stand in it leave the scene there.

    Parameters
    ----------
    walker : Walker
        The run's Algorithm 3 state; its fields so far are ``values`` (raw state values,
        one per field) with goal cells ``goal_cells``.
    grid : GridMap
        The (static) grid the values are solved on.
    dt : float
        Seconds per step.
    leaves : (N,) bool
        Agents that leave on reaching their goal cells from the start (``remove_on_arrival``
        for agents off route).
    region_cells, solve : callable
        ``region_cells(grid, region, what)`` -> the free cells of a region, and
        ``solve(occupancy, cells, params)`` -> its state values (the run's own, from
        :mod:`crowdmotion.mdp.simulation`).
    """

    def __init__(self, walker: Walker, grid: GridMap, params: MDPParams, dt: float, values: np.ndarray,
                 goal_cells: list[np.ndarray], leaves: np.ndarray, region_cells, solve):
        self._region_cells, self._solve = region_cells, solve
        self.walker, self.grid, self.params, self.dt = walker, grid, params, float(dt)
        self.values = list(values)   # raw state values of each field (walking distance = -v × cell)
        self._index: dict[bytes, int] = {}  # goal cells -> field: each area solved once
        self._of_region: dict[int, tuple] = {}  # id(region) -> (region, field)
        for k, gc in enumerate(goal_cells):
            self._index.setdefault(self._key(gc), k)
        self.solves = 0  # fields solved for route areas (the groups' own goals not counted)
        self.leaves = np.asarray(leaves, dtype=bool).copy()
        self.left = np.zeros(len(self.leaves), dtype=bool)

    @staticmethod
    def _key(cells: np.ndarray) -> bytes:
        c = np.asarray(cells, dtype=np.int64)
        return np.unique(c, axis=0).tobytes()

    # ---- what Journeys reads ----------------------------------------------------------
    @property
    def positions(self) -> np.ndarray:
        return self.grid.centers(self.walker.cells)

    @property
    def active(self) -> np.ndarray:
        return self.walker.active == 1

    @property
    def time(self) -> float:
        return self.walker.steps_done * self.dt

    @property
    def arrived(self) -> np.ndarray:
        w = self.walker
        return (w.goal[w.field_of, w.cur] == 1) | self.left

    # ---- what Journeys asks -----------------------------------------------------------
    def field(self, region) -> int:
        """The field index of ``region`` (Rect, Disc or Points), solved the first time."""
        hit = self._of_region.get(id(region))
        if hit is not None and hit[0] is region:
            return hit[1]
        cells = self._region_cells(self.grid, region, "route area")
        key = self._key(cells)
        if key not in self._index:
            occ = self.grid.occupancy
            v = self._solve(occ, cells, self.params)
            self.solves += 1
            depth = fill_depth(occ, cells, self.params.corner_cutting)
            mask = np.zeros(self.grid.shape, dtype=bool)
            mask[tuple(cells.T)] = True
            self._index[key] = self.walker.add_field(v + depth, mask)
            self.values.append(v)
        self._of_region[id(region)] = (region, self._index[key])
        return self._index[key]

    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere: bool = False,
                  leave: bool | None = None) -> None:
        ids = np.atleast_1d(np.asarray(agents, dtype=np.int64))
        region = goal_region if isinstance(goal_region, (Rect, Disc, Points)) else \
            Points(np.asarray(goals, dtype=float).reshape(-1, self.grid.dim))
        self.walker.field_of[ids] = self.field(region)
        if leave is not None:
            self.leaves[ids] = bool(leave)

    def walking_distance(self, points, region) -> np.ndarray:
        """Metres from each point's cell to ``region`` along the grid's values (inf where
        obstacles cut it off)."""
        v = self.values[self.field(region)]
        cells = np.clip(self.grid.cell_of(np.asarray(points, dtype=float)), 0, np.array(self.grid.shape) - 1)
        d = -v[tuple(cells.T)] * self.grid.cell_size
        return np.where(np.isfinite(d), d, np.inf)

    def add_goal_regions(self, regions) -> None:
        """Nothing to do ahead: each area's field is solved when an agent is first sent there."""

    # ---- the run loop -----------------------------------------------------------------
    def after_step(self) -> None:
        """Agents bound for an exit that stand on one of its cells leave the scene."""
        w = self.walker
        out = np.flatnonzero(self.leaves & ~self.left & (w.active == 1) & (w.goal[w.field_of, w.cur] == 1))
        if len(out):
            w.remove(out)
            self.left[out] = True

    def settled(self) -> bool:
        """Every agent in the scene stands on a goal cell of its field, or cannot reach one."""
        w = self.walker
        live = w.active == 1
        here = w.values[w.field_of, w.cur]
        return bool(np.all(~live | (w.goal[w.field_of, w.cur] == 1) | ~np.isfinite(here)))
