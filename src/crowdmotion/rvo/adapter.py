"""The RVO method as the scenario runner and CLI see it: run + progress + summary + plots."""

from __future__ import annotations

import warnings

import numpy as np

from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.journeys import entry_report
from crowdmotion.routing import PASSAGE_SAMPLES
from crowdmotion.rvo.params import RVOParams
from crowdmotion.rvo.personality import PARAM_KEYS
from crowdmotion.rvo.simulation import RVORun, build_journeys, build_simulator, run
from crowdmotion.smoothing import smoothing_report

Params = RVOParams


def check_scenario(scene, groups, params: RVOParams) -> None:
    """Everything a run refuses, refused before it starts: a 3D scene, goals an agent
    cannot stand on, spawn regions too small, then the set-up itself (placement, personality,
    guidance fields) and goals the field says no agent can reach."""
    from crowdmotion.checks import check_dimension, check_entrances, check_goal_clear, check_inside, \
        check_route_places, check_spawn_capacity, describe_region, group_problems, warn_late_entries, where
    from crowdmotion.stages import flat_stages, stage_label

    check_dimension("rvo", scene, (2,), "use method = 'mdp' or 'pso' for 3D scenes")

    def check(k, g) -> None:
        # a route's places first: without a goal of its own the group's goal is its route's first
        # place, which is then named by its stage (route.0 (queue 'kiosk')), not as 'goal'
        check_route_places(scene, k, g)
        check_goal_clear(scene, k, g)
        check_inside(scene, k, g, "spawn")
        check_inside(scene, k, g, "goal")
        check_entrances(scene, k, g)
        warn_late_entries(k, g, params.max_steps * params.time_step, "[rvo] max_steps x time_step")
        # a group entering over time need not fit all at once (build_simulator checks its enter table)
        if "enter" not in g.attributes:
            check_spawn_capacity(scene, k, g, params.spawn_gap)

    group_problems(groups, check)
    given = [key for key in PARAM_KEYS if key in params.model_fields_set]
    if given and groups and all(g.attributes.get("personality") is not None for g in groups):
        warnings.warn(f"rvo.{given[0]} = {getattr(params, given[0])} changes nothing here: every group has a "
                      f"personality, which sets {', '.join(PARAM_KEYS)} (Table 4 of paper 004); [rvo]'s "
                      f"apply to groups without one", stacklevel=2)
    rng = np.random.default_rng(0)
    sim = build_simulator(scene, groups, params, rng)
    journeys = build_journeys(sim, scene, groups, rng)
    try:
        sim.preferred_velocities()  # builds the guidance fields the first step would
    except ValueError as exc:
        raise ValueError(f"rvo guidance: {exc}") from None
    if journeys is not None:  # every place on a route can be walked to from the spawn
        for k, g in enumerate(groups):
            starts = sim.positions[sim.group == k]
            for path, st, _ in flat_stages(g.attributes.get("route") or []):
                region = journeys.region_of(st) if st.kind in ("goto", "queue", "leave") else None
                if region is not None and not np.isfinite(sim.walking_distance(starts, region)).any():
                    raise ValueError(f"{where(k, g)} {stage_label(path, st)}: cannot be reached from the spawn "
                                     f"{describe_region(g.spawn)}: obstacles close the way for a body of radius "
                                     f"{g.radius:g} m{_grid_note(sim)}")
    stranded = sim.unreachable()
    if stranded.any():
        i = int(np.flatnonzero(stranded)[0])
        k = int(sim.group[i])
        raise ValueError(f"{where(k, groups[k])} goal: {describe_region(groups[k].goal)} cannot be reached from "
                         f"the spawn {describe_region(groups[k].spawn)} (e.g. an agent placed at "
                         f"{np.round(sim.positions[i], 2).tolist()}): obstacles close the way for a body of radius "
                         f"{groups[k].radius:g} m{_grid_note(sim)}")


def _grid_note(sim) -> str:
    """What the guidance grid can tell apart, for a message saying the way is closed."""
    cell = sim.guidance_cell
    if cell is None:
        return ""
    return (f" (the guidance grid, rvo.field_cell {cell:.3g} m, opens a passage at least 2 radii plus "
            f"{cell / PASSAGE_SAMPLES:.3g} m wide: a smaller rvo.field_cell opens narrower ones)")


def expected_steps(groups, params: RVOParams) -> int:
    """Steps a run records at most (it stops sooner once everyone has arrived)."""
    return params.max_steps


def step_seconds(groups, params: RVOParams) -> float:
    """Simulated seconds per step."""
    return params.time_step


def expected_frames(groups, params: RVOParams) -> int:
    """Frames of the run's trajectories at most: one per step and the start."""
    return params.max_steps + 1


def output_copy(params: RVOParams) -> bool:
    """Whether the run returns its frames relaxed (``smoothing``) beside the steps it keeps."""
    return params.smoothing == "relaxed"


def run_scenario(scene, groups, params: RVOParams, rng, progress: bool = True):
    with step_bar(params.max_steps, "rvo steps", progress) as bar:
        result = run(scene, groups, params, rng, progress=bar.done)
    traj, sim = result.trajectories, result.simulator
    journeys = result.journeys
    arrived, finished = sim.arrived, sim.arrival_time
    if journeys is not None:  # an agent on a route arrives where its route ends (or it leaves)
        arrived = np.where(journeys.on_route, journeys.done, arrived)
        finished = np.where(journeys.on_route, journeys.finished_at, finished)
    summary = metrics.summary(traj, scene)
    summary["arrival_rate"] = float(arrived.mean())
    taken = finished - sim.entry_time  # from entering (t = 0 for those there from the start)
    summary["mean_time_to_goal_s"] = float(np.nanmean(taken)) if arrived.any() else None
    summary["time_to_goal_by_group_s"] = metrics.time_to_goal_by_group(traj, taken)
    if any("enter" in g.attributes for g in groups):
        summary["entry"] = entry_report(traj.group, sim.enter_at, sim.entry_time, sim.entrance)
    if journeys is not None:
        summary["journeys"] = journeys.report([g.name for g in groups])
    stats = sim.stats
    steps = max(stats["agent_steps"], 1)
    summary.update({
        "method": "rvo",
        "steps": sim.steps,
        "safety_stop_rate": stats["safety_stops"] / steps,
        "forced_choice_rate": stats["forced_choices"] / steps,
        # the model's motion, as paper §6 compares it, with the arrival times measured
        "groups": metrics.with_arrival_times(metrics.group_report(result.steps, scene), summary["time_to_goal_by_group_s"]),
        # a run stopped early (Ctrl-C) keeps its steps as simulated
        "smoothing": smoothing_report(traj, "none" if traj.metadata.get("partial") else params.smoothing,
                                      params.smoothing_window),
    })
    at_limit = sim.steps >= params.max_steps
    stalled = 0
    if at_limit and not arrived.all():  # those standing out a wait are not stuck
        waiting = np.isfinite(journeys.wait_until) if journeys is not None else np.zeros(len(arrived), dtype=bool)
        stalled = metrics.stalled_short(result.steps, sim.goals, arrived | waiting)
    metrics.note_step_limit(summary, "rvo.max_steps", params.max_steps, at_limit, sim.steps * params.time_step,
                            stalled=stalled)
    return traj, result, summary


def write_plots(scene, result: RVORun, out, which, title: str = "") -> list:
    """The RVO run's figures: ``paths`` over the scene, coloured by group (and, for a
    run with routes, ``journeys.png``: its queues and exits over time)."""
    from crowdmotion.render import plot_journeys, plot_paths

    written = []
    if "paths" in which:
        written.append(plot_paths(result.trajectories, scene, out / "paths.png", title=title))
        if result.journeys is not None:
            written.append(plot_journeys(result.journeys, out / "journeys.png", title=title))
    return written
