"""The RVO method as the scenario runner and CLI see it: run + progress + summary + plots."""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from crowdmotion import metrics
from crowdmotion.rvo.params import RVOParams
from crowdmotion.rvo.simulation import RVORun, run

Params = RVOParams


def run_scenario(scene, groups, params: RVOParams, rng, progress: bool = True):
    with tqdm(total=params.max_steps, desc="rvo steps", unit="step", disable=not progress, delay=1.0,
              leave=False) as bar:
        result = run(scene, groups, params, rng, progress=lambda done: bar.update(done - bar.n))
    traj, sim = result.trajectories, result.simulator
    arrived = sim.arrived
    summary = metrics.summary(traj, scene)
    summary["arrival_rate"] = float(arrived.mean())
    summary["mean_time_to_goal_s"] = float(np.nanmean(sim.arrival_time)) if arrived.any() else None
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
