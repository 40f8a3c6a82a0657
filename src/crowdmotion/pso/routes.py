"""Swarms on routes: each PSO group (one swarm) is one walker of
:class:`crowdmotion.journeys.Journeys`.

A swarm follows ``goto``, ``choose`` and ``leave`` stages; following maps onto them: a
stage's area becomes the swarm's target (its centre: a swarm gathers on one point,
:meth:`crowdmotion.pso.Swarm.retarget`), and the swarm arrives once every particle it
still has has stopped there (within the threshold of the target, or joined to the
gathered ones). ``choose`` picks once for the swarm (``nearest`` and ``least_crowded``
weigh straight distances from its centre: PSO flies straight, round obstacles by its
avoidance rules). On a ``leave`` stage each particle leaves the scene as soon as it
stops at the exit (:meth:`Swarm.remove`: no longer stepped, drawn or avoided), so the
exit empties the swarm particle by particle; the swarm has left when its last particle
has. ``wait`` and ``queue`` are refused (a swarm does not stand still in line). The route
logic is the shared state machine's; this module only lets it see swarms.
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Disc, Points, Rect
from crowdmotion.pso.params import STAGES
from crowdmotion.stages import refuse_unfollowed


def check_pso_route(route, where: str) -> None:
    """Refuse a route with a wait or queue stage (a swarm neither waits nor queues), naming it."""
    refuse_unfollowed(route, where, STAGES, "a PSO swarm")


def region_target(region) -> np.ndarray:
    """The point a swarm sent to ``region`` gathers on: its centre."""
    return np.asarray(region.center, float)


class PSOWalkers:
    """The swarms as :class:`crowdmotion.journeys.Walkers` see them: one walker per swarm,
    at the centre of its particles still in the scene, arrived when all of them have
    stopped, gone once the last has left. Call :meth:`after_step` after each
    ``swarm.iterate()`` and before ``journeys.update``: particles of a swarm bound for an
    exit that have stopped there leave the scene.

    ``ids`` holds, for each particle in the swarm, its index in the run (the swarm closes
    up its arrays when particles leave, and appends those that enter); :meth:`frame` gives
    the run's (N, D) positions with those that left at the place they left, and those
    still to enter (:meth:`hold`, :meth:`enter`) at their start."""

    def __init__(self, swarm):
        self.swarm = swarm
        n = swarm.n
        self.ids = np.arange(n)
        self.swarm_of = swarm.swarm.copy()              # each particle's swarm, over the run
        self.radius = swarm.radius.copy()
        self.last = swarm.x.copy()                      # where each particle is, or where it left
        self.present = np.ones(n, bool)
        self.left_arrival = np.full(n, -1, np.int64)    # the iteration each particle that left arrived at
        self.leaves = np.zeros(swarm.n_swarms, bool)
        self.held: dict[int, tuple] = {}                 # swarm -> (run ids, velocities) while off-scene
        self.entered_at = np.zeros(swarm.n_swarms)       # when each swarm entered (NaN while it waits)

    # ---- what Journeys reads ----------------------------------------------------------
    @property
    def positions(self) -> np.ndarray:
        s = self.swarm
        out = s.target.copy()  # a swarm with no particle left: at its target
        counts = np.bincount(s.swarm, minlength=s.n_swarms)
        for d in range(s.dim):
            sums = np.bincount(s.swarm, weights=s.x[:, d], minlength=s.n_swarms)
            out[:, d] = np.where(counts > 0, sums / np.maximum(counts, 1), out[:, d])
        return out

    @property
    def active(self) -> np.ndarray:
        return np.bincount(self.swarm.swarm, minlength=self.swarm.n_swarms) > 0

    @property
    def time(self) -> float:
        return self.swarm.iteration * self.swarm.params.iteration_time

    @property
    def arrived(self) -> np.ndarray:
        s = self.swarm
        moving = np.bincount(s.swarm, weights=~s.stopped, minlength=s.n_swarms)
        return moving == 0

    # ---- what Journeys asks -----------------------------------------------------------
    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere: bool = False,
                  leave: bool | None = None) -> None:
        ids = np.atleast_1d(np.asarray(agents, dtype=np.int64))
        s = self.swarm
        targets = s.target.copy()
        if isinstance(goal_region, (Rect, Disc, Points)):
            targets[ids] = region_target(goal_region)
        else:
            targets[ids] = np.asarray(goals, float).reshape(-1, s.dim)
        which = np.zeros(s.n_swarms, bool)
        which[ids] = True
        s.retarget(targets, which=which)
        if leave is not None:
            self.leaves[ids] = bool(leave)

    def walking_distance(self, points, region) -> np.ndarray:
        """Straight metres from each point to ``region`` (a swarm flies straight)."""
        pts = np.asarray(points, dtype=float).reshape(-1, self.swarm.dim)
        return np.linalg.norm(region.nearest(pts) - pts, axis=1)

    def add_goal_regions(self, regions) -> None:
        """Nothing to do ahead: a swarm needs no guidance field."""

    # ---- the run loop -----------------------------------------------------------------
    def after_step(self) -> None:
        """Particles bound for an exit that have stopped there leave the scene."""
        s = self.swarm
        self.last[self.ids] = s.x
        out = np.flatnonzero(self.leaves[s.swarm] & s.stopped)
        if len(out):
            gone = self.ids[out]
            self.present[gone] = False
            self.left_arrival[gone] = s.arrival_iteration[out]
            s.remove(out)
            self.ids = np.delete(self.ids, out)

    # ---- swarms that enter late -------------------------------------------------------
    def hold(self, swarms) -> None:
        """Keep ``swarms`` off-scene (not stepped, drawn or avoided) until :meth:`enter`:
        their particles stand at their starts with their first velocities kept."""
        s = self.swarm
        for k in np.atleast_1d(np.asarray(swarms, dtype=np.int64)):
            rows = np.flatnonzero(s.swarm == k)
            self.held[int(k)] = (self.ids[rows], s.v[rows].copy())
            self.present[self.ids[rows]] = False
            self.entered_at[k] = np.nan
            s.remove(rows)
            self.ids = np.delete(self.ids, rows)

    def room(self, k: int, gap: float) -> bool:
        """Whether held swarm ``k`` fits at its starts: each particle ``gap`` clear of the
        bodies in the scene (of the largest of them, to be safe)."""
        from scipy.spatial import cKDTree

        ids = self.held[k][0]
        s = self.swarm
        if not s.n:
            return True
        d, _ = cKDTree(s.x).query(self.last[ids])
        return bool(np.all(d >= self.radius[ids] + s.radius.max() + gap))

    def enter(self, k: int, time: float) -> None:
        """Held swarm ``k`` enters at ``time`` (seconds), whole, at its starts."""
        ids, v = self.held.pop(k)
        self.swarm.add(self.last[ids], v, self.swarm_of[ids], self.radius[ids])
        self.ids = np.concatenate([self.ids, ids])
        self.present[ids] = True
        self.entered_at[k] = time

    def frame(self) -> np.ndarray:
        """(N, D) every particle of the run: where it is, or where it left."""
        self.last[self.ids] = self.swarm.x
        return self.last.copy()

    def stopped(self) -> np.ndarray:
        """(N,) particles stopped now, those that left counted as stopped (and those
        still waiting to enter not)."""
        out = ~self.present
        for ids, _ in self.held.values():
            out[ids] = False
        out[self.ids] = self.swarm.stopped
        return out

    def arrival_iteration(self) -> np.ndarray:
        """(N,) the iteration each particle arrived (stopped, or left), -1 if never."""
        out = self.left_arrival.copy()
        out[self.ids] = self.swarm.arrival_iteration
        return out
