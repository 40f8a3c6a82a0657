"""Formations on routes: each group is one walker of :class:`crowdmotion.journeys.Journeys`.

A formation follows every stage but ``queue`` as one unit, keeping its shape between
stages: ``goto`` and ``leave`` send the whole group to the area (:meth:`Simulator.set_goal`;
it arrives when its centre enters the area, then recovers its shape on the area's
centre), ``wait`` holds it where it stands, ``choose`` picks once for the group, and
``leave`` takes the group out of the scene on arrival (:meth:`Simulator.remove_group`).
A stage whose area walls cut the group off from (a door shut while running) holds it
where it stands until a way opens. The route logic is the shared state machine's; this
module only lets it see groups. The simulator owns its walkers
(``crowdmotion.formation.simulator``, which imports this module: nothing is imported back).
"""

from __future__ import annotations

import numpy as np

from crowdmotion.groups import Disc, Points, Rect
from crowdmotion.routing import distance_fields
from crowdmotion.formation.params import STAGES
from crowdmotion.stages import refuse_unfollowed


def check_formation_route(route, where: str) -> None:
    """Refuse a route with a queue stage (a formation does not queue), naming it."""
    refuse_unfollowed(route, where, STAGES, "a formation")


class FormationWalkers:
    """The formation simulator as :class:`crowdmotion.journeys.Walkers` see it: one walker
    per group, at its agents' centre, arrived when the group has arrived in its target
    area, gone once it left. Call :meth:`after_step` after each ``sim.step()`` and before
    ``journeys.update``: a group bound for an exit that has arrived leaves there
    (:meth:`crowdmotion.formation.simulator.Simulator.step` does both).

    ``sim``: the formation :class:`~crowdmotion.formation.simulator.Simulator`."""

    def __init__(self, sim):
        self.sim = sim
        self.leaves = np.zeros(len(sim.groups), dtype=bool)
        self._fields: dict[int, tuple] = {}  # id(region) -> (region, its distance field): solved once ...
        self._fields_in = sim.scene_now  # ... in the scene standing now (an obstacle edit solves them again)

    @property
    def positions(self) -> np.ndarray:
        return np.array([self.sim.positions[g.span].mean(axis=0) for g in self.sim.groups]).reshape(-1, 2)

    @property
    def active(self) -> np.ndarray:
        return np.array([g.in_scene for g in self.sim.groups], dtype=bool)

    @property
    def time(self) -> float:
        return self.sim.time

    @property
    def arrived(self) -> np.ndarray:
        return np.array([g.arrived_at is not None or g.left_at is not None for g in self.sim.groups], dtype=bool)

    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere: bool = False,
                  leave: bool | None = None) -> None:
        ids = np.atleast_1d(np.asarray(agents, dtype=np.int64))
        goals = np.broadcast_to(np.asarray(goals, dtype=float).reshape(-1, 2), (len(ids), 2))
        for k, goal in zip(ids, goals):
            region = goal_region if isinstance(goal_region, (Rect, Disc)) else goal
            self.sim._retarget(int(k), region, refuse_cut_off=False)  # a shut door: it waits
        if len(self.leaves) < len(self.sim.groups):  # groups added since
            self.leaves = np.concatenate([self.leaves, np.zeros(len(self.sim.groups) - len(self.leaves), bool)])
        self.leaves[ids] = bool(leave)

    def walking_distance(self, points, region) -> np.ndarray:
        """Metres from each point to ``region`` round the static obstacles (straight in
        an open scene); each region's field is solved once."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        straight = np.linalg.norm(region.nearest(pts) - pts, axis=1)
        scene = self.sim.scene_now
        if not scene.static_obstacles:
            return straight
        if scene is not self._fields_in:
            self._fields, self._fields_in = {}, scene
        if id(region) not in self._fields:
            radius = float(self.sim.radius.max()) if len(self.sim.radius) else 0.25
            self._fields[id(region)] = (region, distance_fields(scene, [region], radius))
        d = self._fields[id(region)][1].nearby(0, pts)
        return np.where(np.isfinite(d), d, straight)

    def add_goal_regions(self, regions) -> None:
        """Nothing to do ahead: the simulator solves its route field per set of goals, once."""

    def after_step(self) -> None:
        """Groups bound for an exit that arrived there leave the scene."""
        for k, g in enumerate(self.sim.groups[:len(self.leaves)]):
            if self.leaves[k] and g.arrived_at is not None and g.left_at is None:
                self.sim.remove_group(k)
