"""Run the RVO method on a Scene and its Groups and return Trajectories."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Callable, Literal, Sequence

import numpy as np

from crowdmotion import __version__
from crowdmotion.groups import Disc, Group, MovingTarget, Points, Rect
from crowdmotion.placement import spawn_positions
from crowdmotion.rvo.personality import PARAM_KEYS, sample_personalities
from crowdmotion.rvo.simulator import Simulator
from crowdmotion.scene import Scene
from crowdmotion.trajectories import Trajectories


@dataclass(frozen=True)
class RVOParams:
    """Parameters of the RVO method (paper symbols in brackets).

    time_step : float        simulation step Δt, seconds
    max_steps : int          stop after this many steps even if agents are still walking
    max_neighbors : int      [M] nearest neighbours considered (groups without a personality)
    neighbor_dist : float    [D] metres within which neighbours count
    samples : int            [N_sample] random candidate velocities per agent and step
    safety : float           [w] weight of 1/tc in the penalty, eq. (3)
    dominant : "abs"|"max"   f(ψ): largest |ψk| (default) or the paper's literal max ψk
    guidance : str           "auto", "direct" or "field" (exact MDP distance field)
    field_cell : float|None  guidance grid cell, metres (default: agent radius)
    remove_on_arrival : bool agents leave once within arrival_radius of their goal
    arrival_radius : float   metres
    goal_assignment : str    how region goals become points: "sample" (uniform in the goal
                             region) or "shift" (start + goal centre − spawn centre,
                             clamped into the region: everyone walks straight across)
    spawn_gap : float        extra clearance, metres, between agents sampled in a region
    """

    time_step: float = 0.25
    max_steps: int = 2000
    max_neighbors: int = 10
    neighbor_dist: float = 10.0
    samples: int = 50
    safety: float = 5.0
    dominant: Literal["abs", "max"] = "abs"
    guidance: Literal["auto", "direct", "field"] = "auto"
    field_cell: float | None = None
    remove_on_arrival: bool = True
    arrival_radius: float = 0.5
    goal_assignment: Literal["sample", "shift"] = "sample"
    spawn_gap: float = 0.05

    def __post_init__(self):
        checks = {
            "time_step": self.time_step > 0, "max_steps": self.max_steps >= 1,
            "max_neighbors": self.max_neighbors >= 0, "neighbor_dist": self.neighbor_dist > 0,
            "samples": self.samples >= 1, "safety": self.safety >= 0, "arrival_radius": self.arrival_radius > 0,
            "spawn_gap": self.spawn_gap >= 0,
        }
        for name, ok in checks.items():
            v = getattr(self, name)
            if not ok or not np.isfinite(v):
                raise ValueError(f"rvo.{name} is out of range: got {v!r}")
        for name, allowed in (("dominant", ("abs", "max")), ("guidance", ("auto", "direct", "field")),
                              ("goal_assignment", ("sample", "shift"))):
            if getattr(self, name) not in allowed:
                raise ValueError(f"rvo.{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if self.field_cell is not None and not (np.isfinite(self.field_cell) and self.field_cell > 0):
            raise ValueError(f"rvo.field_cell must be a positive number of metres, got {self.field_cell!r}")


def goal_points(group: Group, starts: np.ndarray, assignment: str, rng: np.random.Generator):
    """Per-agent goal points (or the MovingTarget itself) for a group."""
    goal = group.goal
    if isinstance(goal, MovingTarget):
        return goal
    if isinstance(goal, Points):
        if len(goal.points) == group.count:
            return goal.points.copy()
        if len(goal.points) == 1:
            return np.tile(goal.points[0], (group.count, 1))
        raise ValueError(f"group {group.name!r} goal: {len(goal.points)} points for {group.count} agents "
                         "(give one point, or one per agent)")
    if assignment == "shift":
        pts = starts + (goal.center - group.spawn.center)
        if isinstance(goal, Rect):
            return np.clip(pts, goal.lower, goal.upper)
        if isinstance(goal, Disc):
            off = pts - goal.center
            d = np.linalg.norm(off, axis=1, keepdims=True)
            return np.where(d > goal.radius, goal.center + off / np.maximum(d, 1e-12) * goal.radius, pts)
    return goal.sample(group.count, rng)


def build_simulator(scene: Scene, groups: Sequence[Group], params: RVOParams, rng: np.random.Generator) -> Simulator:
    """A Simulator holding every group's agents, placed and personalised."""
    sim = Simulator(scene, params.time_step, guidance=params.guidance, remove_on_arrival=params.remove_on_arrival,
                    arrival_radius=params.arrival_radius, field_cell=params.field_cell, dominant=params.dominant,
                    rng=rng)
    placed = np.zeros((0, 2))
    placed_r = np.zeros(0)
    for k, g in enumerate(groups):
        if g.dim != 2:
            raise ValueError(f"groups.{k} ({g.name!r}): the RVO method is 2D, the group is {g.dim}D")
        starts = spawn_positions(scene, g, placed, placed_r, params.spawn_gap, rng)
        goals = goal_points(g, starts, params.goal_assignment, rng)
        persona = g.attributes.get("personality")
        try:
            if persona is None:
                kw = {key: g.attributes.get(key, getattr(params, key)) for key in PARAM_KEYS}
            else:
                kw = {"personality": sample_personalities(persona, g.count, rng, f"groups.{k}.personality")}
            sim.add_agents(starts, goals, radius=g.radius, max_speed=g.max_speed, pref_speed=g.pref_speed,
                           goal_region=g.goal, **kw)
        except ValueError as exc:
            raise ValueError(f"groups.{k} ({g.name!r}): {exc}") from None
        placed = np.vstack([placed, starts])
        placed_r = np.append(placed_r, np.full(len(starts), g.radius))
    return sim


@dataclass
class RVORun:
    """A finished RVO run: the trajectories and the simulator in its final state."""

    trajectories: Trajectories
    simulator: Simulator


def run(scene: Scene, groups: Sequence[Group], params: RVOParams, rng: np.random.Generator,
        progress: Callable[[int], None] | None = None) -> RVORun:
    """Step until every agent has arrived (or ``max_steps``); frames are the steps."""
    sim = build_simulator(scene, groups, params, rng)
    frames = [sim.positions.copy()]
    present = [sim.present.copy()]
    while sim.steps < params.max_steps and sim.active.any():
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())
        if progress is not None and sim.steps % 10 == 0:
            progress(sim.steps)
    names = np.array([g.name for g in groups], dtype=object)
    active = np.array(present)
    traj = Trajectories(
        np.array(frames), params.time_step, group=names[sim.group], radius=sim.params["radius"],
        active=None if active.all() else active,
        metadata={"method": "rvo", "params": asdict(params), "scene": scene.to_dict(), "version": __version__,
                  "steps": sim.steps, "stats": dict(sim.stats),
                  "personality": sim.personality.tolist()},
    )
    return RVORun(traj, sim)


def simulate(scene: Scene, groups: Sequence[Group], params: RVOParams | None = None,
             rng: np.random.Generator | None = None) -> Trajectories:
    """The RVO method end to end: ``rvo.simulate(scene, groups, params, rng) -> Trajectories``."""
    params = RVOParams() if params is None else params
    rng = np.random.default_rng(0) if rng is None else rng
    return run(scene, groups, params, rng).trajectories
