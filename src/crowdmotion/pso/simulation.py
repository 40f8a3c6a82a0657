"""The particle-swarm method on a Scene and its Groups: one swarm per group, all stepped
together (each group is an obstacle to the others), output as Trajectories."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from crowdmotion.groups import Disc, Group, MovingTarget, Points, Rect
from crowdmotion.interrupts import step_loop
from crowdmotion.placement import spawn_groups
from crowdmotion.pso.obstacles import obstacle_field
from crowdmotion.pso.params import PSOParams, make_params, warn_fast_clamp
from crowdmotion.pso.swarm import Swarm, SwarmRun, drive, follow_schedule
from crowdmotion.scene import Scene
from crowdmotion.trajectories import Trajectories


@dataclass
class PSORun:
    """``trajectories`` (at ``params.fps``, relaxed or straight between the iterates as
    ``params.smoothing`` says), the raw ``swarm_run`` (one frame per iteration), and the
    ``scene`` that was used (generated obstacles included)."""

    trajectories: Trajectories
    swarm_run: SwarmRun
    scene: Scene
    group_names: list[str]
    journeys: Any = None  # the route state machine (crowdmotion.journeys.Journeys), None without routes
    due: np.ndarray | None = None  # (N,) when each particle's swarm was due to enter (groups with enter), s
    entered_at: np.ndarray | None = None  # (N,) when it entered (NaN: still waiting at the end), s


def _region_box(region) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(region, Rect):
        return region.lower, region.upper
    if isinstance(region, Disc):
        return region.center - region.radius, region.center + region.radius
    if isinstance(region, Points):
        return region.points.min(axis=0), region.points.max(axis=0)
    return region.positions.min(axis=0), region.positions.max(axis=0)  # MovingTarget


def _target(group: Group, t: float = 0.0) -> np.ndarray:
    """A swarm has one target: a point goal, a region's centre, or a moving target at t."""
    if isinstance(group.goal, MovingTarget):
        return group.goal.at(t)
    return np.asarray(group.goal.center, float)


def generated_obstacles(groups: Sequence[Group], params: PSOParams, dim: int, rng: np.random.Generator) -> list:
    """The obstacles ``params.obstacle_field`` generates for these groups: over the box
    spanned by their spawns and targets (unless the field gives its own), clear of every
    target."""
    targets0 = np.array([_target(g) for g in groups]).reshape(len(groups), dim)
    boxes = [_region_box(g.spawn) for g in groups] + [_region_box(g.goal) if isinstance(g.goal, MovingTarget)
                                                      else (t, t) for g, t in zip(groups, targets0)]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    moving_targets = [g.goal.positions for g in groups if isinstance(g.goal, MovingTarget)]
    keep_clear = np.concatenate([targets0, *moving_targets]) if moving_targets else targets0
    return obstacle_field(params.obstacle_field, dim, lo, hi, keep_clear, params.threshold, rng)


def run(scene: Scene, groups: Sequence[Group], params: PSOParams | None = None,
        rng: np.random.Generator | None = None, progress: Callable[[int], None] | None = None) -> PSORun:
    """Gather or follow for every group; returns the run with its Trajectories.

    Groups with a fixed goal gather on its centre for ``params.iterations`` iterations (or
    until every particle has stopped); groups with a moving goal follow it, the target
    being read every ``params.iterations`` iterations (see :func:`crowdmotion.pso.follow`).
    A group with ``enter = { start = s }`` is a swarm that enters whole at its spawn at
    the first iteration at or after ``s`` seconds its particles are clear of every body
    (:func:`_run_stepped`).
    """
    params = make_params(params) if not isinstance(params, PSOParams) else params
    rng = np.random.default_rng() if rng is None else rng
    if not groups:
        raise ValueError("pso: at least one group is needed")
    dim = scene.dim
    targets0 = np.array([_target(g) for g in groups]).reshape(len(groups), dim)
    obstacles = list(scene.obstacles)
    if params.obstacle_field is not None:
        obstacles += generated_obstacles(groups, params, dim, rng)
    used = Scene(scene.bounds, obstacles)
    try:
        xs, rs, sw = spawn_groups(used, groups, params.spawn_gap, rng, overlap=not params.avoid_agents)
    except ValueError as exc:
        raise ValueError(f"pso: {exc}") from None
    swarm = Swarm(xs, sw, targets0, rs, params, used, rng)
    if any(g.attributes.get("route") is not None or "enter" in g.attributes for g in groups):
        return _run_stepped(swarm, groups, params, rng, progress)
    moving = np.array([isinstance(g.goal, MovingTarget) for g in groups])
    schedule = None
    if moving.any():
        paths = [g.goal for g in groups if isinstance(g.goal, MovingTarget)]
        schedule = follow_schedule(min(p.times[0] for p in paths), max(p.times[-1] for p in paths), params.iterations,
                                   params.iteration_time)
    result = drive(swarm, schedule, lambda t: np.array([_target(g, t) for g in groups]), moving, progress)
    names = [g.name for g in groups]
    max_speed = np.array([g.max_speed for g in groups])[result.swarm]
    return PSORun(result.trajectories(names, params.fps, max_speed=max_speed), result, used, names)


def _run_stepped(swarm: Swarm, groups: Sequence[Group], params: PSOParams, rng: np.random.Generator,
                 progress: Callable[[int], None] | None) -> PSORun:
    """:func:`run` when a group has a route or enters late: one iteration at a time.

    A swarm with ``enter = { start = s }`` waits off-scene (not stepped, drawn or
    avoided: :meth:`PSOWalkers.hold`) until the first iteration k with
    k · iteration_time ≥ s at which every particle of it stands ``params.spawn_gap``
    clear of the bodies in the scene (with ``avoid_agents``; without, at k), then enters
    whole at its starts, its memories fresh. After each iteration the route state machine
    moves swarms on (:mod:`crowdmotion.pso.routes`); the run ends once every swarm has
    entered and gathered at its route's end or goal, or left: at most
    ``params.max_iterations`` iterations with routes, else ``params.iterations`` after
    the last swarm entered (its gathering budget). ``Trajectories.stage`` says each
    particle's stage per frame (with routes) and ``active`` which particles are in the
    scene."""
    from crowdmotion._rng import step_key
    from crowdmotion.checks import where
    from crowdmotion.journeys import Journeys, unit_entry_time
    from crowdmotion.pso.routes import PSOWalkers, check_pso_route

    routes = [g.attributes.get("route") for g in groups]
    for k, g in enumerate(groups):
        if isinstance(g.goal, MovingTarget):
            what = "pso routes need fixed goals" if any(r is not None for r in routes) else \
                "a swarm entering late needs a fixed goal"
            raise ValueError(f"{where(k, g)} goal: {what}; a moving target is followed on its own, "
                             f"without routes or enter in the scene")
        if routes[k] is not None:
            check_pso_route(routes[k], where(k, g))
    due = np.array([unit_entry_time(g.attributes.get("enter"), f"{where(k, g)}: enter", "a PSO swarm")
                    for k, g in enumerate(groups)])
    it = params.iteration_time
    due_iteration = np.ceil(due / it - 1e-9).astype(np.int64)
    walkers = PSOWalkers(swarm)
    later = np.array(["enter" in g.attributes for g in groups])
    walkers.hold(np.flatnonzero(later))
    gap = params.spawn_gap if params.avoid_agents else -np.inf

    def admit(iteration: int) -> None:
        for k in sorted(walkers.held, key=lambda k: (due[k], k)):  # the earlier due first
            if due_iteration[k] <= iteration and walkers.room(k, gap):
                walkers.enter(k, iteration * it)

    admit(0)
    journeys = Journeys(routes, np.arange(len(groups)), [g.spawn for g in groups],
                        [float(walkers.radius[walkers.swarm_of == k].max()) for k in range(len(groups))],
                        [g.pref_speed for g in groups], step_key(rng))
    journeys.update(walkers, it)
    routed = any(r is not None for r in routes)

    def stage_now():
        return np.where(walkers.present, journeys.frame(walkers.active)[walkers.swarm_of], -1).astype(np.int16)

    def last_iteration() -> int:  # routes: the cap; else the gathering budget after the last entry
        if routed:
            return params.max_iterations
        last = len(frames) - 1 if walkers.held else int(np.nanmax(walkers.entered_at) / it + 0.5)
        return min(params.max_iterations, last + params.iterations)

    frames, targets, present, stages = [walkers.frame()], [swarm.target.copy()], [walkers.present.copy()], [stage_now()]
    with step_loop() as loop:  # Ctrl-C: keep the iterations so far, marked partial
        while len(frames) <= last_iteration() and (swarm.n or walkers.held):
            swarm.iterate()
            walkers.after_step()  # particles at their exit leave; swarms that arrived move on
            admit(swarm.iteration)
            journeys.update(walkers, it)
            frames.append(walkers.frame())
            targets.append(swarm.target.copy())
            present.append(walkers.present.copy())
            stages.append(stage_now())
            if progress is not None:
                progress(1)
            if swarm.done and not journeys.busy(walkers.active) and not walkers.held \
                    and (routed or params.stop_when_done):
                break
    partial = loop.stopped
    n = min(len(frames), len(targets), len(present), len(stages))
    active, stage = np.array(present[:n]), np.array(stages[:n])
    sr = SwarmRun(np.array(frames[:n]), walkers.swarm_of.copy(), np.array(targets[:n]), walkers.stopped(),
                  walkers.arrival_iteration(), walkers.radius.copy(), swarm.scene, params, swarm.stats,
                  params.iteration_time, partial, active=None if active.all() else active,
                  stage=stage if routed else None,
                  stages=journeys.stage_table([g.name for g in groups]) if routed else None)
    names = [g.name for g in groups]
    max_speed = np.array([g.max_speed for g in groups])[sr.swarm]
    entry = (due[walkers.swarm_of], walkers.entered_at[walkers.swarm_of]) if later.any() else (None, None)
    return PSORun(sr.trajectories(names, params.fps, max_speed=max_speed), sr, swarm.scene, names,
                  journeys if routed else None, *entry)


def expected_steps(groups, params: PSOParams) -> int:
    """Iterations a run records at most: k, or k per target update when targets move
    (capped at ``max_iterations``); gathering may stop sooner."""
    paths = [g.goal for g in groups if isinstance(g.goal, MovingTarget)]
    updates = 1
    if paths:
        updates = len(follow_schedule(min(p.times[0] for p in paths), max(p.times[-1] for p in paths),
                                      params.iterations, params.iteration_time)) + 1
    return min(updates * params.iterations, params.max_iterations)


def simulate(scene: Scene, groups: Sequence[Group], params: PSOParams | None = None,
             rng: np.random.Generator | None = None, progress: bool = False) -> Trajectories:
    """The particle-swarm method end to end: ``pso.simulate(scene, groups, params, rng) -> Trajectories``;
    warns, as a scenario's check does, when pso.v_max lets a particle outrun its group's
    max_speed; ``progress=True`` shows the command's bar of iterations on stderr
    (``crowdmotion.progress.step_bar``)."""
    from crowdmotion.progress import step_bar

    params = make_params(params)
    warn_fast_clamp(scene, groups, params)
    with step_bar(expected_steps(groups, params), "pso", progress, unit="iteration") as bar:
        return run(scene, groups, params, np.random.default_rng(0) if rng is None else rng,
                   progress=bar.advance).trajectories
