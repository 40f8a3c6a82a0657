"""The particle-swarm method as the scenario runner and CLI see it: run, progress bar,
summary, figures."""

from __future__ import annotations

import warnings

import numpy as np
from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.groups import MovingTarget, Points
from crowdmotion.pso.obstacles import ObstacleArrays
from crowdmotion.pso.params import PSOParams
from crowdmotion.pso.simulation import PSORun, run

Params = PSOParams


def check_scenario(scene, groups, params: PSOParams) -> None:
    from crowdmotion.checks import check_spawn_capacity, where

    for i, g in enumerate(groups):  # the placement run does: listed starts, room when bodies keep apart
        if isinstance(g.spawn, Points) or params.avoid_agents:
            check_spawn_capacity(scene, i, g, params.spawn_gap)
    # the paper's clamp is per axis and per iteration: say so when it allows more than a group's max_speed
    top = float(np.linalg.norm(params.axis_vmax(scene.dim))) / params.iteration_time
    for i, g in enumerate(groups):
        if top > g.max_speed * (1 + 1e-9):
            warnings.warn(f"{where(i, g)}: pso.v_max {params.axis_vmax(scene.dim)} per "
                          f"{params.iteration_time:g} s iteration lets a particle move at up to {top:.2f} m/s, above "
                          f"the group's max_speed {g.max_speed:g} m/s (PSO clamps per axis, as the paper does); "
                          f"lower pso.v_max or raise pso.iteration_time to keep to it", stacklevel=2)

    """Problems a scenario can be refused for before running: obstacle kinds, v_max axes,
    targets covered by an obstacle."""
    ObstacleArrays.from_scene(scene)
    params.axis_vmax(scene.dim)
    for i, g in enumerate(groups):
        points = g.goal.positions if isinstance(g.goal, MovingTarget) else np.asarray(g.goal.center)[None]
        clear = scene.obstacle_distance(points, 0.0)
        if np.any(clear < g.radius):
            bad = points[int(np.argmin(clear))].tolist()
            raise ValueError(f"{where(i, g)} goal: the target {bad} is covered by an obstacle "
                             f"(clearance {clear.min():.3g} m < radius {g.radius} m)")


def expected_steps(groups, params: PSOParams) -> int:
    """Iterations a run records at most: k, or k per target update when targets move
    (capped at ``max_iterations``); gathering may stop sooner."""
    from crowdmotion.pso.swarm import follow_schedule

    paths = [g.goal for g in groups if isinstance(g.goal, MovingTarget)]
    updates = 1
    if paths:
        updates = len(follow_schedule(min(p.times[0] for p in paths), max(p.times[-1] for p in paths),
                                      params.iterations, params.iteration_time)) + 1
    return min(updates * params.iterations, params.max_iterations)


def run_scenario(scene, groups, params: PSOParams, rng, progress: bool = True):
    with step_bar(expected_steps(groups, params), "pso iterations", progress, unit="it") as bar:
        result = run(scene, groups, params, rng, progress=bar.advance)
    sr = result.swarm_run
    traj = result.trajectories
    summary = metrics.summary(traj, result.scene)
    names = np.array(result.group_names, dtype=object)[sr.swarm]
    arrived = sr.arrival_iteration >= 0
    summary.update({
        "method": "pso",
        "iterations": int(sr.paths.shape[0] - 1),
        "arrival_rate": sr.arrival_rate,
        "within_threshold_rate": float(sr.within_threshold().mean()),
        "mean_time_to_goal_s": float(sr.arrival_iteration[arrived].mean() * sr.iteration_time) if arrived.any()
        else None,
        "time_to_goal_by_group_s": metrics.time_to_goal_by_group(
            traj, np.where(arrived, sr.arrival_iteration * sr.iteration_time, np.nan)),
        "groups_gathered": {n: bool(sr.stopped[names == n].all()) for n in result.group_names},
        "rules": dict(sr.stats),
        "generated_obstacles": len(result.scene.obstacles) - len(scene.obstacles),
        "groups": metrics.group_report(traj),
    })
    return traj, result, summary


def write_plots(scene, result: PSORun, out, which, title: str = "") -> list:
    """``paths``: every particle's path over the scene (generated obstacles included),
    with the targets (a moving target's positions at each update) as stars/squares."""
    from crowdmotion.render import plot_paths

    written = []
    if "paths" in which:
        targets = np.unique(result.swarm_run.targets.reshape(-1, result.scene.dim), axis=0)
        written.append(plot_paths(result.trajectories, result.scene, out / "paths.png", title=title, goals=targets))
    return written
