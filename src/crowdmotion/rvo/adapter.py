"""The RVO method as the scenario runner and CLI see it: run + progress + summary + plots."""

from __future__ import annotations

import numpy as np
from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.journeys import entry_report
from crowdmotion.rvo.params import RVOParams
from crowdmotion.rvo.simulation import RVORun, build_simulator, run

Params = RVOParams


def check_scenario(scene, groups, params: RVOParams) -> None:
    """Everything a run refuses, refused before it starts: a 3D scene, goals an agent
    cannot stand on, spawn regions too small, then the set-up itself (placement, personality,
    guidance fields) and goals the field says no agent can reach."""
    from crowdmotion.checks import check_dimension, check_goal_clear, check_inside, check_spawn_capacity, \
        describe_region, where

    check_dimension("rvo", scene, (2,), "use method = 'mdp' or 'pso' for 3D scenes")
    for k, g in enumerate(groups):
        check_goal_clear(scene, k, g)
        check_inside(scene, k, g, "spawn")
        check_inside(scene, k, g, "goal")
        # a group entering over time need not fit all at once (build_simulator checks its enter table)
        if "enter" not in g.attributes:
            check_spawn_capacity(scene, k, g, params.spawn_gap)
    sim = build_simulator(scene, groups, params, np.random.default_rng(0))
    try:
        sim.preferred_velocities()  # builds the guidance fields the first step would
    except ValueError as exc:
        raise ValueError(f"rvo guidance: {exc}") from None
    stranded = sim.unreachable()
    if stranded.any():
        i = int(np.flatnonzero(stranded)[0])
        k = int(sim.group[i])
        raise ValueError(f"{where(k, groups[k])} goal: {describe_region(groups[k].goal)} cannot be reached from "
                         f"the spawn {describe_region(groups[k].spawn)} (e.g. an agent placed at "
                         f"{np.round(sim.positions[i], 2).tolist()}): obstacles close the way for a body of radius "
                         f"{groups[k].radius:g} m")


def expected_steps(groups, params: RVOParams) -> int:
    """Steps a run records at most (it stops sooner once everyone has arrived)."""
    return params.max_steps


def step_seconds(groups, params: RVOParams) -> float:
    """Simulated seconds per step."""
    return params.time_step


def expected_frames(groups, params: RVOParams) -> int:
    """Frames of the run's trajectories at most: one per step and the start."""
    return params.max_steps + 1


def run_scenario(scene, groups, params: RVOParams, rng, progress: bool = True):
    with step_bar(params.max_steps, "rvo steps", progress) as bar:
        result = run(scene, groups, params, rng, progress=bar.done)
    traj, sim = result.trajectories, result.simulator
    arrived = sim.arrived
    summary = metrics.summary(traj, scene)
    summary["arrival_rate"] = float(arrived.mean())
    taken = sim.arrival_time - sim.entry_time  # from entering (t = 0 for those there from the start)
    summary["mean_time_to_goal_s"] = float(np.nanmean(taken)) if arrived.any() else None
    summary["time_to_goal_by_group_s"] = metrics.time_to_goal_by_group(traj, taken)
    if any("enter" in g.attributes for g in groups):
        summary["entry"] = entry_report(traj.group, sim.enter_at, sim.entry_time)
    stats = sim.stats
    steps = max(stats["agent_steps"], 1)
    summary.update({
        "method": "rvo",
        "steps": sim.steps,
        "safety_stop_rate": stats["safety_stops"] / steps,
        "forced_choice_rate": stats["forced_choices"] / steps,
        "groups": metrics.group_report(traj),
    })
    return traj, result, summary


def write_plots(scene, result: RVORun, out, which, title: str = "") -> list:
    """The RVO run's figures: ``paths`` over the scene, coloured by group."""
    from crowdmotion.render import plot_paths

    written = []
    if "paths" in which:
        written.append(plot_paths(result.trajectories, scene, out / "paths.png", title=title))
    return written
