"""The MDP method as the scenario runner and CLI see it: run + progress + summary."""

from __future__ import annotations

import numpy as np
from crowdmotion.progress import step_bar

from crowdmotion import metrics
from crowdmotion.journeys import entry_report
from crowdmotion.mdp.params import MDPParams
from crowdmotion.mdp.simulation import MDPRun, run, setup
from crowdmotion.smoothing import smoothing_report

Params = MDPParams


def goal_test(result: MDPRun):
    """``positions -> (N,) bool``: who stands on a cell of their own group's goal."""
    grid = result.grid
    field_of = result.field_of
    masks = []
    for gc in result.goal_cells:
        m = np.zeros(grid.shape, dtype=bool)
        m[tuple(gc.T)] = True
        masks.append(m)
    masks = np.stack(masks)

    def reached(pos):
        cells = np.clip(grid.cell_of(pos), 0, np.array(grid.shape) - 1)
        return masks[(field_of, *cells.T)]

    return reached


def check_scenario(scene, groups, params: MDPParams) -> None:
    """Everything a run refuses, refused before it starts: the set-up itself (cell size,
    goal and spawn cells, slots, room for every agent, entry tables and entrances), then a
    goal no agent can reach."""
    from crowdmotion.checks import check_entrances, check_route_places, describe_region, group_problems, \
        warn_late_entries, where
    from crowdmotion.mdp.routes import check_mdp_route
    from crowdmotion.mdp.simulation import region_cells
    from crowdmotion.mdp.solvers import exact_values, exact_values_each
    from crowdmotion.stages import flat_stages, stage_label

    def check(k, g) -> None:
        check_entrances(scene, k, g)
        if "enter" in g.attributes:
            warn_late_entries(k, g, params.max_steps * step_seconds(groups, params), "[mdp] max_steps x its step time")
        if g.attributes.get("route") is not None:
            check_mdp_route(g.attributes["route"], where(k, g))
            check_route_places(scene, k, g)
            if scene.moving_obstacles:
                raise ValueError(f"{where(k, g)} route: the MDP method follows routes in static scenes only "
                                 f"(moving obstacles re-solve every field as they move)")

    group_problems(groups, check)
    su = setup(scene, groups, params, np.random.default_rng(0))
    for k, g in enumerate(groups):  # every place on a route can be walked to from the spawn
        starts = su.starts[su.field_of == k]
        for path, st, _ in flat_stages(g.attributes.get("route") or []):
            area = getattr(st, "area", None)
            if area is None:
                continue
            at = f"{where(k, g)} {stage_label(path, st)}"
            cells = region_cells(su.grid, area, f"{at} area")
            values = exact_values(su.grid.occupancy, [tuple(c) for c in cells], params.corner_cutting)
            if not np.isfinite(values[tuple(starts.T)]).any():
                raise ValueError(f"{at}: cannot be reached from the spawn {describe_region(g.spawn)}: obstacles "
                                 f"cut the way on the grid of {su.cell:.3g} m cells")
    goal_sets = [[tuple(c) for c in su.goal_cells[k]] for k in range(len(groups))]
    goal_values = exact_values_each(su.grid.occupancy, goal_sets, params.corner_cutting)
    for k, (g, values) in enumerate(zip(groups, goal_values)):
        starts = su.starts[su.field_of == k]
        if not np.isfinite(values[tuple(starts.T)]).any():
            raise ValueError(f"{where(k, g)} goal: no agent can reach {describe_region(g.goal)} from its spawn "
                             f"{describe_region(g.spawn)}: obstacles cut the way on the grid of "
                             f"{su.cell:.3g} m cells")


def expected_steps(groups, params: MDPParams) -> int:
    """Steps a run records at most (it stops sooner once everyone has arrived)."""
    return params.max_steps


def step_seconds(groups, params: MDPParams) -> float:
    """Simulated seconds per step at most (``simulation.step_time`` with diagonal moves)."""
    from crowdmotion.mdp.simulation import cell_size_for, step_time

    return step_time(groups, params, cell_size_for(groups, params), float(np.sqrt(groups[0].dim)))


def expected_frames(groups, params: MDPParams) -> int:
    """Frames of the run's trajectories at most: one per step, or ``fps`` a second when
    smoothed."""
    if params.smoothing is None:
        return params.max_steps + 1
    return int(params.max_steps * step_seconds(groups, params) * params.fps) + 1


def run_scenario(scene, groups, params: MDPParams, rng, progress: bool = True):
    with step_bar(params.max_steps, "mdp steps", progress) as bar:
        result = run(scene, groups, params, rng, progress=bar.done)
    traj = result.trajectories
    at_goal = goal_test(result)
    summary = metrics.summary(traj, scene, at_goal)
    journeys = result.journeys
    if journeys is not None:  # an agent on a route arrives where its route ends (or it leaves)
        got, when = metrics.arrival(traj, at_goal)
        arrived = np.where(journeys.on_route, journeys.done, got)
        finished = np.where(journeys.on_route, journeys.finished_at, when)
        summary["arrival_rate"] = float(arrived.mean())
        summary["mean_time_to_goal_s"] = float(np.nanmean(finished)) if arrived.any() else None
        summary["time_to_goal_by_group_s"] = metrics.time_to_goal_by_group(traj, finished)
        summary["journeys"] = journeys.report([g.name for g in groups])
        summary["route_fields_solved"] = result.walkers.solves
    field_of = result.field_of
    last = result.grid.cell_of(traj.positions[-1])
    last = np.clip(last, 0, np.array(result.grid.shape) - 1)
    dist = -result.values[(field_of, *last.T)] * result.grid.cell_size
    summary.update({
        "method": "mdp",
        "cell_size_m": result.grid.cell_size,
        "grid_shape": list(result.grid.shape),
        "steps": traj.metadata["steps"],
        "unreachable_agents": result.unreachable.tolist(),
        "mean_final_path_distance_to_goal_m": float(np.mean(dist[np.isfinite(dist)])) if np.isfinite(dist).any() else None,
        "max_final_path_distance_to_goal_m": float(np.max(dist[np.isfinite(dist)])) if np.isfinite(dist).any() else None,
    })
    metrics.note_step_limit(summary, "mdp.max_steps", params.max_steps, traj.metadata["steps"] >= params.max_steps,
                            summary["duration_s"])
    if result.arrivals is not None:  # each group's delay (and each entrance's), seconds on the run's time base
        a = result.arrivals
        summary["entry"] = entry_report(traj.group, a.due, a.entered_at(result.walker), a.entrance)
    # how the paths were relaxed (at fps, or at the run's own steps for a large run:
    # path_relaxation.RELAX_AT_FPS_MAX) is in the smoothing report
    summary["smoothing"] = smoothing_report(traj, params.smoothing or "none", params.smoothing_window)
    return traj, result, summary


def write_plots(scene, result: MDPRun, out, which, title: str = "") -> list:
    """The MDP run's figures: ``paths`` over the scene (and, for a run with routes,
    ``journeys.png``: its exits over time) and the ``values`` field of group 0."""
    from crowdmotion.render import plot_journeys, plot_paths, plot_values

    written = []
    goals = np.concatenate([result.grid.centers(gc) for gc in result.goal_cells])
    if "paths" in which:
        written.append(plot_paths(result.trajectories, scene, out / "paths.png", title=title, goals=goals))
        if result.journeys is not None:
            written.append(plot_journeys(result.journeys, out / "journeys.png", title=title))
    if "values" in which:
        # with moving obstacles the field is re-solved at every step: the last one is drawn
        when = (f"\nat the end, t = {result.trajectories.times[-1]:.0f} s: moving obstacles where they stood then"
                if any(ob.is_moving for ob in scene.obstacles) else "")
        written.append(plot_values(result.values[0], out / "values.png", result.grid.cell_size,
                                   tuple(result.grid.origin), title=f"{title}: state values{when}",
                                   goal_cells=result.goal_cells[0]))
    return written
