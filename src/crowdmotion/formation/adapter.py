"""The formation method as the scenario runner and CLI see it: run, progress bar,
summary with the formation measures, figures."""

from __future__ import annotations

import numpy as np
from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.formation.params import FormationParams
from crowdmotion.formation.simulation import FormationRun, build_simulator, run
from crowdmotion.journeys import entry_report

Params = FormationParams


def check_scenario(scene, groups, params: FormationParams) -> None:
    """Problems a scenario can be refused for before running: a goal outside the bounds
    or where a body cannot stand, a 3D scene, a template that does not match the count,
    duplicate or blocked starts, a goal that walls cut off from the formation's start."""
    from crowdmotion.checks import check_goal_clear, check_inside, check_route_places, describe_region, \
        group_problems, warn_late_entries, where
    from crowdmotion.formation.routes import check_formation_route

    def check(k, g) -> None:
        warn_late_entries(k, g, params.max_steps * params.time_step, "[formation] max_steps x time_step")
        if g.dim == scene.dim:  # (a 3D group is refused, by name, as the simulator is built)
            if g.attributes.get("route") is not None:  # first: a route's first place may be its goal
                check_formation_route(g.attributes["route"], where(k, g))
                check_route_places(scene, k, g)
            check_goal_clear(scene, k, g)
            check_inside(scene, k, g, "goal")

    group_problems(groups, check)
    sim = build_simulator(scene, groups, params, np.random.default_rng(0))
    try:
        stranded = sim.cut_off()
    except ValueError as exc:
        raise ValueError(f"formation route: {exc}") from None
    if stranded:
        k = stranded[0]
        raise ValueError(f"{where(k, groups[k])} goal: {describe_region(groups[k].goal)} cannot be reached from the "
                         f"spawn {describe_region(groups[k].spawn)}: walls close the way")


def expected_steps(groups, params: FormationParams) -> int:
    """Steps a run records at most (it stops sooner once every group has recovered)."""
    return params.max_steps


def step_seconds(groups, params: FormationParams) -> float:
    """Simulated seconds per step."""
    return params.time_step


def expected_frames(groups, params: FormationParams) -> int:
    """Frames of the run's trajectories at most: one per step, or ``fps`` a second."""
    if params.fps is None:
        return params.max_steps + 1
    return int(params.max_steps * params.time_step * params.fps) + 1


def run_scenario(scene, groups, params: FormationParams, rng, progress: bool = True):
    with step_bar(params.max_steps, "formation steps", progress) as bar:
        result = run(scene, groups, params, rng, progress=bar.advance)
    traj = result.trajectories
    summary = metrics.summary(traj, scene)
    sim = result.simulator
    # each formation's time to its goal, from entering, as one unit (its agents stay there)
    by_group = {}
    for g in sim.groups:
        arrived = (result.report.get(g.name) or {}).get("arrived_s")
        by_group[g.name] = None if arrived is None or g.entered_at is None else float(arrived - g.entered_at)
    summary.update({
        "method": "formation",
        "steps": sim.steps,
        "all_recovered": sim.done,
        "formation": result.report,
        **({} if result.journeys is None else {"journeys": result.journeys.report([g.name for g in groups])}),
        "rules": dict(sim.stats),
        "time_to_goal_by_group_s": by_group,
        "groups": metrics.with_arrival_times(metrics.group_report(traj, scene), by_group),
    })
    if any("enter" in g.attributes for g in groups):  # each formation's delay, as one unit
        due = np.array([g.enter_at for g in sim.groups])[sim.group_of]
        entered = np.array([np.nan if g.entered_at is None else g.entered_at for g in sim.groups])[sim.group_of]
        summary["entry"] = entry_report(traj.group, due, entered)
    metrics.note_step_limit(summary, "formation.max_steps", params.max_steps, sim.steps >= params.max_steps,
                            sim.steps * params.time_step, short=not sim.done)
    return traj, result, summary


def snapshot_steps(result: FormationRun) -> list[tuple[int, str]]:
    """Four moments worth showing: the start, the most deformed step, halfway from there
    to the end, and the end."""
    err = np.max([np.concatenate([[0.0], g.edge_error]) for g in result.simulator.groups], axis=0)
    last = len(result.frames) - 1
    worst = int(np.argmax(err))
    return [(0, "start"), (worst, "most deformed"), ((worst + last) // 2, "recovering"), (last, "end")]


ANIMATION_FRAMES = 120

# [output] plots names that stand for pictures drawn apart, side by side where cores allow
# (crowdmotion.outputs.picture_parts): the snapshots figure and its GIF
PICTURE_PARTS = {"snapshots": ("snapshots-figure", "snapshots-animation")}


def write_plots(scene, result: FormationRun, out, which, title: str = "") -> list:
    """``paths``: every agent's path; ``values``: the static obstacles' potential field
    (``field.png``); ``snapshots``: the meshes at four moments (``snapshots-figure``
    alone) and an animated GIF of the whole run (``formation.gif``, at most 120 frames;
    ``snapshots-animation`` alone)."""
    from crowdmotion.render import animate_formation_snapshots, plot_formation_snapshots, plot_journeys, \
        plot_paths, plot_potential_field

    written = []
    if "paths" in which:
        goals = np.array([g.goal_center for g in result.simulator.groups])
        written.append(plot_paths(result.trajectories, scene, out / "paths.png", title=title, goals=goals))
        if result.journeys is not None:  # a run with routes: its exits over time
            written.append(plot_journeys(result.journeys, out / "journeys.png", title=title))
    if "values" in which and scene.obstacles:
        field = result.simulator.field
        written.append(plot_potential_field(scene, field.static_f, field.static_vec, field.cell, out / "field.png",
                                            title=f"{title}: obstacle potential field, r = {field.reach} m"))
    dt = result.simulator.dt
    if "snapshots" in which or "snapshots-figure" in which:
        snaps = [{"time": s * dt, "label": label, "groups": result.snapshot(s)} for s, label in snapshot_steps(result)]
        written.append(plot_formation_snapshots(scene, snaps, out / "snapshots.png", title=title))
    if "snapshots" in which or "snapshots-animation" in which:
        steps = np.unique(np.linspace(0, len(result.frames) - 1, ANIMATION_FRAMES).astype(int))
        frames = [{"time": s * dt, "groups": result.snapshot(s)} for s in steps]
        fps = len(steps) / max(1.0, min(12.0, (len(result.frames) - 1) * dt / 4))
        written.append(animate_formation_snapshots(scene, frames, out / "formation.gif", fps=fps, title=title))
    return written
