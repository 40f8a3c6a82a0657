"""MDP groups that enter over time: each agent due at a step enters at a free cell of its entrance.

A group's ``enter`` table (:mod:`crowdmotion.journeys`: a rate, a start, an end, times,
entrances) gives each agent the second it is due. An MDP run steps a fixed time ``dt``
known before it starts (:func:`crowdmotion.mdp.simulation.step_time` with the longest
move, a diagonal: cell size over the slowest preferred speed, lengthened so that a
diagonal stays within every max_speed), so an agent due at ``t`` seconds is due at the
first frame ``k`` with ``k · dt ≥ t``. Until it enters it waits off-scene: inactive in
Algorithm 3 (on no cell, not stepped, not avoided) and absent from the trajectories.
From its frame on, at the end of each step it enters at a cell of its entrance that no
agent and no obstacle takes (drawn from the run's generator among the free ones; a
listed spawn point keeps its own cell), so it never overlaps anyone; while none is free
it waits on. Agents due together enter in order of their times, then of their ids. A
spawn listing one point per agent keeps each agent to its own point's cell; any other
area (one point for the whole group, say: a door) is a pool of cells the group shares.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from crowdmotion.checks import where
from crowdmotion.groups import Group, Points
from crowdmotion.journeys import entrance_areas, entrance_of, entry_times
from crowdmotion.mdp.grid import GridMap
from crowdmotion.mdp.trajectory import Walker

WAITING = np.iinfo(np.int64).max  # Walker.entered_frame of an agent still off-scene


class Arrivals:
    """Who enters when, and where, for a run with groups that enter over time.

    Parameters
    ----------
    grid : GridMap
        The run's grid.
    groups : sequence of Group
        All the run's groups; those without ``enter`` are in the scene from frame 0.
    dt : float
        Seconds per step, fixed before the run.
    rng : numpy Generator
        Draws each agent's entrance and its first cell.
    region_cells : callable
        ``region_cells(grid, region, what)`` -> the free cells of a region
        (:func:`crowdmotion.mdp.simulation.region_cells`).

    Attributes
    ----------
    due : (N,) float
        The second each agent is due (0 for agents of groups without ``enter``).
    due_frame : (N,) int
        The first frame it may enter in.
    entrance : (N,) int
        Its entrance (an index into its group's ``enter.entrances``; -1: the spawn).
    first : (N, D) int
        The cell it is drawn to enter at (its own listed spawn point's cell, kept).
    later : (N,) bool
        Agents of groups with ``enter`` (off-scene until :meth:`admit` lets them in).
    """

    def __init__(self, grid: GridMap, groups: Sequence[Group], dt: float, rng: np.random.Generator,
                 region_cells: Callable):
        n = sum(g.count for g in groups)
        self.dt = float(dt)
        self.due = np.zeros(n)
        self.entrance = np.full(n, -1, dtype=np.int64)
        self.first = np.zeros((n, grid.dim), dtype=np.int64)
        self.later = np.zeros(n, dtype=bool)
        self.pools: list[np.ndarray] = []           # the cells of each entrance of each group
        self.pool_of = np.full(n, -1, dtype=np.int64)  # each agent's pool (-1: its own cell only)
        start = 0
        for k, g in enumerate(groups):
            own = slice(start, start + g.count)
            start += g.count
            spec = g.attributes.get("enter")
            if spec is None:
                continue
            at = f"{where(k, g)}: enter"
            self.later[own] = True
            self.due[own] = entry_times(spec, g.count, at)
            doors = entrance_of(spec, g.count, rng, at)
            if doors is not None:
                self.entrance[own] = doors
            areas = entrance_areas(spec, at)
            ids = np.arange(own.start, own.stop)
            for j in np.unique(self.entrance[own]):
                mine = ids[self.entrance[own] == j]
                area = g.spawn if j < 0 else areas[j]
                cells = region_cells(grid, area, f"{where(k, g)} " + ("spawn" if j < 0 else f"enter.entrances.{j}"))
                if j < 0 and isinstance(area, Points) and len(cells) == g.count:  # one point an agent: its own
                    self.first[mine] = cells
                    continue
                cells = np.unique(cells, axis=0)
                self.pool_of[mine] = len(self.pools)
                self.pools.append(cells)
                self.first[mine] = cells[rng.integers(len(cells), size=len(mine))]
        self.due_frame = np.ceil(self.due / self.dt - 1e-9).astype(np.int64)
        self.waiting = self.later.copy()

    @property
    def pending(self) -> bool:
        """Some agent has not entered yet."""
        return bool(self.waiting.any())

    def steps_to_next(self, frame: int) -> int:
        """Steps from ``frame`` to the next frame an agent may enter in (≥ 1; a large
        number when none waits)."""
        if not self.pending:
            return WAITING
        return max(1, int(self.due_frame[self.waiting].min()) - frame)

    def admit(self, walker: Walker, frame: int, rng: np.random.Generator) -> np.ndarray:
        """Let in, at ``frame`` (the walker's steps done), the waiting agents due by then
        that find a free cell; return their ids."""
        ids = np.flatnonzero(self.waiting & (self.due_frame <= frame))
        if not len(ids):
            return ids
        ids = ids[np.lexsort((ids, self.due[ids]))]
        fixed = ids[self.pool_of[ids] < 0]
        cand = fixed[walker.free(self.first[fixed])]
        _, one = np.unique(self.first[cand], axis=0, return_index=True)  # one agent a cell
        cand = cand[np.sort(one)]
        walker.enter(cand, self.first[cand])
        entered = [cand]
        for p in np.unique(self.pool_of[ids]):
            if p < 0:
                continue
            who = ids[self.pool_of[ids] == p]
            cells = self.pools[p][walker.free(self.pools[p])]
            m = min(len(who), len(cells))
            if m:
                walker.enter(who[:m], cells[rng.choice(len(cells), size=m, replace=False)])
                entered.append(who[:m])
        got = np.concatenate(entered)
        self.waiting[got] = False
        return got

    def entered_at(self, walker: Walker) -> np.ndarray:
        """(N,) the second each agent entered (NaN while it waits)."""
        frame = walker.entered_frame
        return np.where(frame == WAITING, np.nan, frame * self.dt)
