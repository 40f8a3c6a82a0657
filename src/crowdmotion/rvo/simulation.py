"""Run the RVO method on a Scene and its Groups and return Trajectories."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from crowdmotion import __version__
from crowdmotion.checks import where
from crowdmotion.groups import Disc, Group, MovingTarget, Points, Rect
from crowdmotion._rng import step_key
from crowdmotion.interrupts import step_loop
from crowdmotion.journeys import Journeys, entrance_of, entry_points, entry_times
from crowdmotion.path_relaxation import relaxed_steps
from crowdmotion.placement import spawn_positions
from crowdmotion.rvo.params import RVOParams
from crowdmotion.rvo.personality import PARAM_KEYS, personality_metadata, sample_personalities
from crowdmotion.rvo.simulator import Simulator
from crowdmotion.scene import Scene
from crowdmotion.trajectories import Trajectories, held_absent


def goal_points(group: Group, starts: np.ndarray, assignment: str, rng: np.random.Generator):
    """Per-agent goal points (or the MovingTarget itself) for a group. The Simulator moves
    a point no body of the agent's radius stands on to where it fits
    (``Simulator.add_agents``)."""
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
    if assignment == "nearest":
        return goal.nearest(starts)
    if assignment == "shift":
        pts = starts + (goal.center - group.spawn.center)
        if isinstance(goal, Rect):
            return np.clip(pts, goal.lower, goal.upper)
        if isinstance(goal, Disc):
            off = pts - goal.center
            d = np.linalg.norm(off, axis=1, keepdims=True)
            return np.where(d > goal.radius, goal.center + off / np.maximum(d, 1e-12) * goal.radius, pts)
    return goal.sample(group.count, rng)


def preferred_speeds(group: Group, rng: np.random.Generator):
    """The group's pref_speed, or one speed per agent drawn uniformly from
    ``attributes["pref_speed_range"] = [low, high]`` (m/s, within max_speed): walking speeds
    that differ, as RiMEA test 7 asks (Weidmann's age groups)."""
    spec = group.attributes.get("pref_speed_range")
    if spec is None:
        return group.pref_speed
    try:
        lo, hi = (float(v) for v in spec)
    except (TypeError, ValueError):
        raise ValueError(f"attributes.pref_speed_range must be [low, high] in m/s, got {spec!r}") from None
    if not (0 < lo <= hi <= group.max_speed):
        raise ValueError(f"attributes.pref_speed_range must satisfy 0 < low <= high <= max_speed "
                         f"({group.max_speed:g}), got {spec!r}")
    return rng.uniform(lo, hi, group.count)


def build_simulator(scene: Scene, groups: Sequence[Group], params: RVOParams, rng: np.random.Generator) -> Simulator:
    """A Simulator holding every group's agents, placed and personalised."""
    sim = Simulator(scene, params.time_step, guidance=params.guidance, remove_on_arrival=params.remove_on_arrival,
                    arrival_radius=params.arrival_radius, field_cell=params.field_cell, dominant=params.dominant,
                    rng=rng, keep_right_deg=params.keep_right_deg, patience=params.patience,
                    congestion=params.congestion, counterflow=params.counterflow, replan_s=params.replan_s,
                    density_slowing=params.density_slowing, follow=params.follow,
                    lane_choice=params.lane_choice, comfort_accel=params.comfort_accel,
                    squeeze_past=params.squeeze_past, counterflow_safety=params.counterflow_safety,
                    pass_standing=params.pass_standing, held_horizon=params.held_horizon)
    placed = np.zeros((0, 2))
    placed_r = np.zeros(0)
    for k, g in enumerate(groups):
        if g.dim != 2:
            raise ValueError(f"{where(k, g)}: the RVO method is 2D, the group is {g.dim}D")
        enter = g.attributes.get("enter")
        due = None if enter is None else entry_times(enter, g.count, f"{where(k, g)}: enter")
        doors = None if enter is None else entrance_of(enter, g.count, rng, f"{where(k, g)}: enter")
        # a group entering over time takes its places one by one: they need not all fit at once
        starts = spawn_positions(scene, g, placed, placed_r, params.spawn_gap, rng, overlap=enter is not None) \
            if doors is None else entry_points(scene, g, doors, params.spawn_gap, rng)
        goals = goal_points(g, starts, params.goal_assignment, rng)
        persona = g.attributes.get("personality")
        both = [key for key in PARAM_KEYS if persona is not None and key in g.attributes]
        if both:  # the Simulator refuses the same clash in add_agents
            raise ValueError(f"{where(k, g)} attributes.{both[0]}: the group's personality {persona!r} sets "
                             f"{', '.join(PARAM_KEYS)} (Table 4 of paper 004); give either the personality or "
                             f"those attributes")
        try:
            if persona is None:
                kw = {key: g.attributes.get(key, getattr(params, key)) for key in PARAM_KEYS}
            else:
                kw = {"personality": sample_personalities(persona, g.count, rng, f"groups.{k}.personality")}
            anywhere = params.goal_assignment == "nearest" and isinstance(g.goal, (Rect, Disc))
            sim.add_agents(starts, goals, radius=g.radius, max_speed=g.max_speed,
                           pref_speed=preferred_speeds(g, rng), goal_region=g.goal, enter_at=due,
                           arrive_anywhere=anywhere, entrance=doors, **kw)
        except ValueError as exc:
            raise ValueError(f"{where(k, g)}: {exc}") from None
        if enter is None:
            placed = np.vstack([placed, starts])
            placed_r = np.append(placed_r, np.full(len(starts), g.radius))
    return sim


def retry_entries(sim: Simulator, scene: Scene, groups: Sequence[Group], params: RVOParams,
                  rng: np.random.Generator) -> None:
    """Agents due to enter whose place is taken try a fresh point of their entrance (or
    their group's spawn region) at the next step (a listed spawn point is kept)."""
    due = sim.waiting & (sim.enter_at <= sim.time + 1e-9)
    if not due.any():
        return
    for k, g in enumerate(groups):
        ids = np.flatnonzero(due & (sim.group == k))
        if len(ids) and ((sim.entrance[ids] >= 0).any() or not isinstance(g.spawn, Points)):
            sim.set_entry_points(ids, entry_points(scene, g, sim.entrance[ids], params.spawn_gap, rng))


def build_journeys(sim: Simulator, scene: Scene, groups: Sequence[Group],
                   rng: np.random.Generator) -> Journeys | None:
    """The state machine that walks the agents of groups with a ``route`` attribute
    along it (None when no group has one: ``rng`` is then left untouched), attached to
    ``sim`` (``sim.journeys``: each step moves them on), with the guidance fields of
    every stage made known to ``sim`` so they are solved once."""
    routes = [g.attributes.get("route") for g in groups]
    if all(r is None for r in routes):
        return None

    journeys = Journeys(routes, sim.group, [g.spawn for g in groups], sim.params["radius"],
                        sim.params["pref_speed"], step_key(rng), scene.clearance)
    sim.add_goal_regions(journeys.regions())
    sim.journeys = journeys  # each step moves the agents on along their routes
    return journeys


@dataclass
class RVORun:
    """A finished RVO run: the trajectories (relaxed for characters, ``params.smoothing``),
    the simulator in its final state, the route state machine (None without routes), and
    the steps as simulated (``trajectories`` itself when they are not relaxed): the
    model's motion, which the paper's §6 measures compare."""

    trajectories: Trajectories
    simulator: Simulator
    journeys: Journeys | None = None
    steps: Trajectories | None = None

    def __post_init__(self):
        if self.steps is None:
            self.steps = self.trajectories


def run(scene: Scene, groups: Sequence[Group], params: RVOParams, rng: np.random.Generator,
        progress: Callable[[int], None] | None = None) -> RVORun:
    """Step until every agent has arrived (or ``max_steps``); frames are the steps, relaxed
    for the characters that play them (``params.smoothing``; the live :class:`Simulator`
    gives the steps as simulated)."""
    sim = build_simulator(scene, groups, params, rng)
    journeys = build_journeys(sim, scene, groups, rng)
    if journeys is not None:
        journeys.update(sim, params.time_step)
    frames = [sim.positions.copy()]
    present = [sim.present.copy()]
    stages = [] if journeys is None else [journeys.frame(present[0])]
    with step_loop() as loop:  # Ctrl-C: keep the frames so far, marked partial
        entering = any("enter" in g.attributes for g in groups)
        while sim.steps < params.max_steps and ((sim.active & ~sim.arrived).any() or sim.waiting.any()
                                                or (journeys is not None and journeys.busy(sim.active))):
            sim.step()
            if entering:
                retry_entries(sim, scene, groups, params, rng)
            if journeys is not None:  # sim.step moved them on along their routes
                stages.append(journeys.frame(sim.present))
            frames.append(sim.positions.copy())
            present.append(sim.present.copy())
            if progress is not None and sim.steps % 10 == 0:
                progress(sim.steps)
    if progress is not None and sim.steps % 10:  # the last steps too: the bar's count is the run's
        progress(sim.steps)
    partial = loop.stopped
    n = min(len(frames), len(present), len(stages) if journeys is not None else len(frames))
    names = np.array([g.name for g in groups], dtype=object)
    active = np.array(present[:n])
    metadata = {"method": "rvo", "params": params.model_dump(), "scene": scene.to_dict(), "version": __version__,
                "steps": sim.steps, "stats": dict(sim.stats),
                **personality_metadata(sim.personality), "partial": partial}
    if journeys is not None:
        metadata["stages"] = journeys.stage_table(names)
    traj = Trajectories(
        held_absent(np.array(frames[:n]), active), params.time_step, group=names[sim.group],
        radius=sim.params["radius"], active=None if active.all() else active, metadata=metadata,
        stage=None if journeys is None else np.array(stages[:n]),
    )
    steps = traj
    if params.smoothing == "relaxed" and not partial:  # Ctrl-C: the steps so far, at once
        traj = relaxed_steps(traj, params.smoothing_window, scene, sim.params["max_speed"])
    return RVORun(traj, sim, journeys, steps)


def simulate(scene: Scene, groups: Sequence[Group], params: RVOParams | dict | None = None,
             rng: np.random.Generator | None = None, progress: bool = False) -> Trajectories:
    """The RVO method end to end: ``rvo.simulate(scene, groups, params, rng) -> Trajectories``;
    ``params`` an RVOParams or a dict of its fields (validated as the scenario's [rvo]);
    ``progress=True`` shows the command's bar of steps on stderr (``crowdmotion.progress.step_bar``)."""
    if isinstance(params, dict):
        params = RVOParams(**params)
    elif params is None:
        params = RVOParams()
    elif not isinstance(params, RVOParams):
        raise TypeError(f"rvo.simulate: params must be an RVOParams or a dict of its fields, "
                        f"got {type(params).__name__}")
    rng = np.random.default_rng(0) if rng is None else rng
    from crowdmotion.progress import step_bar

    with step_bar(params.max_steps, "rvo steps", progress) as bar:
        return run(scene, groups, params, rng, progress=bar.done).trajectories
