"""The particle-swarm method as the scenario runner and CLI see it: run, progress bar,
summary, figures."""

from __future__ import annotations

import warnings

import numpy as np
from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.journeys import entry_report
from crowdmotion.groups import MovingTarget, Points
from crowdmotion.pso.obstacles import ObstacleArrays
from crowdmotion.pso.params import PSOParams, warn_fast_clamp
from crowdmotion.pso.simulation import PSORun, expected_steps, run
from crowdmotion.smoothing import smoothing_report

Params = PSOParams


FIELD_DRAWS = 3  # obstacle fields drawn to see whether the spawns keep room to start


def check_scenario(scene, groups, params: PSOParams) -> None:
    """Everything a run refuses, refused before it starts: obstacles the swarm cannot
    take (polygons, moving ones), v_max axes, goals outside the bounds or covered,
    listed starts outside the bounds, in obstacles or on top of each other, spawn
    regions too small, goals walled off from their spawns, and a generated obstacle
    field that leaves a spawn no room to start; routes with a wait or queue stage, an
    area outside the bounds or whose centre (where the swarm gathers) is covered, beside
    a moving target or a generated obstacle field. Warns when v_max lets a particle move
    faster than its group's max_speed."""
    from crowdmotion.checks import check_goal_clear, check_inside, check_reachable, check_route_places, \
        check_spawn_capacity, check_start_points, group_problems, where
    from crowdmotion.journeys import unit_entry_time
    from crowdmotion.pso.routes import check_pso_route, region_target
    from crowdmotion.stages import flat_stages, stage_label

    ObstacleArrays.from_scene(scene)
    params.axis_vmax(scene.dim)
    routed = [i for i, g in enumerate(groups) if g.attributes.get("route") is not None]
    if routed and params.obstacle_field is not None:
        raise ValueError(f"pso.obstacle_field: {where(routed[0], groups[routed[0]])} has a route; generated "
                         f"obstacles keep clear of the groups' goals only, not of route areas: place obstacles "
                         f"in [scene] instead")
    for i in routed:
        g = groups[i]
        check_pso_route(g.attributes["route"], where(i, g))
        if isinstance(g.goal, MovingTarget) or any(isinstance(h.goal, MovingTarget) for h in groups):
            raise ValueError(f"{where(i, g)} route: pso routes need fixed goals; a moving target is followed "
                             f"on its own, without routes in the scene")
        check_route_places(scene, i, g)
        for path, st, _ in flat_stages(g.attributes["route"]):
            area = getattr(st, "area", None)
            if area is None:
                continue
            point = region_target(area)[None]
            clear = scene.obstacle_distance(point, 0.0)
            if clear[0] < g.radius:
                raise ValueError(f"{where(i, g)} {stage_label(path, st)} "
                                 f"area: its centre {point[0].tolist()}, where the swarm gathers, is covered by an "
                                 f"obstacle (clearance {clear[0]:.3g} m < radius {g.radius} m)")
    def check(i, g) -> None:
        if "enter" in g.attributes:  # one swarm, one time: enter = { start = s }
            unit_entry_time(g.attributes["enter"], f"{where(i, g)}: enter", "a PSO swarm")
            if any(isinstance(h.goal, MovingTarget) for h in groups):
                raise ValueError(f"{where(i, g)} enter: a swarm entering late needs fixed goals in the scene; "
                                 f"moving targets are followed on their own: leave enter out")
        check_goal_clear(scene, i, g)
        points = g.goal.positions if isinstance(g.goal, MovingTarget) else np.asarray(g.goal.center)[None]
        clear = scene.obstacle_distance(points, 0.0)  # the swarm's target is the goal's centre
        if np.any(clear < g.radius):
            bad = points[int(np.argmin(clear))].tolist()
            raise ValueError(f"{where(i, g)} goal: the target {bad} is covered by an obstacle "
                             f"(clearance {clear.min():.3g} m < radius {g.radius} m)")
        if isinstance(g.goal, MovingTarget):  # and where the swarm reads it, between the keyframes
            _check_target_path(scene, i, g, params)
        check_inside(scene, i, g, "spawn")
        check_inside(scene, i, g, "goal")

    group_problems(groups, check)
    check_start_points(scene, groups, apart=params.avoid_agents)
    for i, g in enumerate(groups):  # the placement run does: listed starts, room when bodies keep apart
        if isinstance(g.spawn, Points) or params.avoid_agents:
            check_spawn_capacity(scene, i, g, params.spawn_gap)
    for i, g in enumerate(groups):
        check_reachable(scene, i, g)
    if params.obstacle_field is not None:
        _check_field(scene, groups, params)
    warn_fast_clamp(scene, groups, params)


def _check_target_path(scene, i: int, g, params: PSOParams) -> None:
    """Refuse a moving target that lies in an obstacle at a time the swarm reads it (every
    ``iterations`` iterations from its first keyframe), naming the time and the keyframes
    it lies between: the run would stop there."""
    from crowdmotion.checks import where
    from crowdmotion.pso.swarm import follow_schedule

    times = follow_schedule(g.goal.times[0], g.goal.times[-1], params.iterations, params.iteration_time)
    points = g.goal.at(times)
    clear = scene.obstacle_distance(points, 0.0)
    if np.any(clear < g.radius):
        k = int(np.argmax(clear < g.radius))
        after = int(np.searchsorted(g.goal.times, times[k], side="right"))
        between = (f"between its keyframes at {g.goal.times[after - 1]:g} and {g.goal.times[after]:g} s"
                   if 0 < after < len(g.goal.times) else "at a keyframe")
        raise ValueError(f"{where(i, g)} goal: the moving target passes through an obstacle: at t = {times[k]:g} s "
                         f"({between}, where the swarm reads it every {params.iterations} iterations of "
                         f"{params.iteration_time:g} s) it is at {np.round(points[k], 3).tolist()}, clearance "
                         f"{clear[k]:.3g} m < radius {g.radius} m; add a keyframe that leads it round")


def _check_field(scene, groups, params: PSOParams) -> None:
    """Refuse an obstacle field that cannot be generated, or that in each of
    ``FIELD_DRAWS`` draws leaves some group's spawn region room for fewer agents than
    its count (the run would fail placing them, after long tries)."""
    from scipy.spatial import cKDTree

    from crowdmotion.checks import describe_region, spawn_room, where
    from crowdmotion.pso.simulation import generated_obstacles

    spec = params.obstacle_field
    short = {}
    for draw in range(FIELD_DRAWS):
        obstacles = generated_obstacles(groups, params, scene.dim, np.random.default_rng(draw))
        tree = cKDTree(np.array([o.center for o in obstacles]))

        def clearance(points):
            return tree.query(points)[0] - spec.radius

        for i, g in enumerate(groups):
            if isinstance(g.spawn, Points):
                continue
            room, _ = spawn_room(scene, g, params.spawn_gap, clearance)
            if g.count > room:
                short.setdefault(i, []).append(room)
    for i, rooms in short.items():
        if len(rooms) == FIELD_DRAWS:
            g = groups[i]
            raise ValueError(f"pso.obstacle_field: {spec.count} obstacles of radius {spec.radius:g} m leave "
                             f"{where(i, g)} room for at most {max(rooms)} agents in its spawn "
                             f"{describe_region(g.spawn)} (in each of {FIELD_DRAWS} draws), but count = {g.count}: "
                             f"lower pso.obstacle_field.count or radius, or set its lower and upper corners away "
                             f"from the spawn")


def step_seconds(groups, params: PSOParams) -> float:
    """Simulated seconds per iteration."""
    return params.iteration_time


def expected_frames(groups, params: PSOParams) -> int:
    """Frames of the run's trajectories at most: one per iteration, or ``fps`` a second."""
    steps = expected_steps(groups, params)
    return steps + 1 if params.fps is None else int(steps * params.iteration_time * params.fps) + 1


def run_scenario(scene, groups, params: PSOParams, rng, progress: bool = True):
    with step_bar(expected_steps(groups, params), "pso", progress, unit="iteration") as bar:
        result = run(scene, groups, params, rng, progress=bar.advance)
    sr = result.swarm_run
    traj = result.trajectories
    summary = metrics.summary(traj, result.scene)
    names = np.array(result.group_names, dtype=object)[sr.swarm]
    arrived = sr.arrival_iteration >= 0
    # seconds from entering (t = 0 for swarms there from the start) to the goal
    entered = np.zeros(len(arrived)) if result.entered_at is None else np.nan_to_num(result.entered_at)
    taken = np.where(arrived, sr.arrival_iteration * sr.iteration_time - entered, np.nan)
    by_group = metrics.time_to_goal_by_group(traj, taken)
    summary.update({
        "method": "pso",
        "iterations": int(sr.paths.shape[0] - 1),
        "arrival_rate": sr.arrival_rate,
        "within_threshold_rate": float(sr.within_threshold().mean()),
        "mean_time_to_goal_s": float(taken[arrived].mean()) if arrived.any() else None,
        "time_to_goal_by_group_s": by_group,
        "groups_gathered": {n: bool(sr.stopped[names == n].all()) for n in result.group_names},
        "rules": dict(sr.stats),
        "generated_obstacles": len(result.scene.obstacles) - len(scene.obstacles),
        "smoothing": smoothing_report(traj, params.smoothing, params.smoothing_window),
        "groups": metrics.with_arrival_times(metrics.group_report(traj, result.scene), by_group),
        **({} if result.journeys is None else {"journeys": result.journeys.report(result.group_names)}),
    })
    if result.due is not None:  # each swarm's delay, as one unit
        summary["entry"] = entry_report(names, result.due, result.entered_at)
    # a run not interrupted ends at its iterations (k, or k after each target update, the
    # last one past the target's last keyframe; within max_iterations) or when everyone is in
    capped = summary["iterations"] >= params.max_iterations
    metrics.note_step_limit(summary, "pso.max_iterations" if capped else "pso.iterations",
                            params.max_iterations if capped else params.iterations,
                            not traj.metadata.get("partial", False), summary["iterations"] * params.iteration_time,
                            stalled=metrics.stalled_short(traj, sr.targets[-1][sr.swarm], arrived))
    return traj, result, summary


def write_plots(scene, result: PSORun, out, which, title: str = "") -> list:
    """``paths``: every particle's path over the scene (generated obstacles included),
    with the targets (a moving target's positions at each update) as stars/squares."""
    from crowdmotion.render import plot_paths

    written = []
    if "paths" in which:
        targets = np.unique(result.swarm_run.targets.reshape(-1, result.scene.dim), axis=0)
        tracks = []  # each swarm's target over the run, as the swarm read it (a moving one changes)
        for track in np.moveaxis(result.swarm_run.targets, 1, 0):
            moved = np.r_[True, np.any(np.diff(track, axis=0) != 0, axis=1)]
            if moved.sum() > 1:
                tracks.append(track[moved])
        written.append(plot_paths(result.trajectories, result.scene, out / "paths.png", title=title, goals=targets,
                                  goal_paths=tracks))
    return written
