"""MDP crowd runs on a Scene: rasterise, solve per goal, Algorithm 3, world-space output."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from crowdmotion.checks import describe_region, region_box
from crowdmotion.groups import Group, Lattice, MovingTarget, Points
from crowdmotion.interrupts import step_loop
from crowdmotion.mdp.goal_fill import fill_depth, nearest_cells
from crowdmotion.mdp.params import MDPParams
from crowdmotion.mdp.grid import GridMap, mark_obstacle, max_radius, min_cell_size, rasterise
from crowdmotion.mdp.sources import Arrivals
from crowdmotion.mdp.solvers import solve, value_iteration
from crowdmotion.mdp.trajectory import Walker
from crowdmotion.scene import Scene
from crowdmotion.progress import step_bar
from crowdmotion.path_relaxation import RELAX_AT_FPS_MAX, STEP_RATE_ITERATIONS, relaxed_trajectories  # noqa: F401
from crowdmotion.smoothing import resample_checked
from crowdmotion.trajectories import Trajectories, held_absent, held_stages


@dataclass
class MDPRun:
    """Everything a scene run produced, for plots and reports."""

    trajectories: Trajectories
    grid: GridMap
    values: np.ndarray  # (groups, *grid) final value field of each group's goal
    goal_cells: list[np.ndarray]
    unreachable: np.ndarray  # agent indices whose start could not reach their goal
    field_of: np.ndarray  # group (value field) index of each agent
    journeys: Any = None  # the route state machine (crowdmotion.journeys.Journeys), None without routes
    walkers: Any = None  # its view of the grid (crowdmotion.mdp.routes.MDPWalkers): fields solved, who left
    arrivals: Arrivals | None = None  # who entered when (groups with ``enter``), None without
    walker: Walker | None = None  # Algorithm 3's state at the end (each agent's entry frame)


def cell_size_for(groups: Sequence[Group], params: MDPParams) -> float:
    r = max(g.radius for g in groups)
    need = min_cell_size(r)
    if params.cell_size is None:
        return need * 1.001
    if params.cell_size <= need:
        raise ValueError(
            f"mdp.cell_size {params.cell_size} m is too small for agents of radius {r} m: the paper "
            f"needs cell > sqrt(2) x diameter = {need:.4f} m"
        )
    return float(params.cell_size)


#: said beside a cell count: a small group's regions are counted in the largest body's cells
ONE_GRID = " (one grid for every group: by default its cells fit the largest body)"


def step_time(groups: Sequence[Group], params: MDPParams, cell: float, longest: float) -> float:
    """Seconds per step of Algorithm 3: a cell at the slowest group's preferred speed (the
    paper's time base, one cell per step), and with ``speed_limited_steps`` at least long
    enough that the longest move, ``longest`` cells (a diagonal, √2 or √3: the length in
    the paper's reward −1, −√2, −√3), stays within every group's max_speed. All agents
    step together, so one time serves all."""
    dt = cell / min(g.pref_speed for g in groups)
    if params.speed_limited_steps:
        dt = max(dt, cell * longest / min(g.max_speed for g in groups))
    return float(dt)


def region_cells(grid: GridMap, region, what: str) -> np.ndarray:
    """Free cells whose centre lies in ``region`` (or the cell of each point for Points)."""
    if isinstance(region, MovingTarget):
        raise ValueError(f"{what}: the MDP method needs a fixed goal, not a moving target")
    if isinstance(region, Points):
        cells = grid.cell_of(region.points)
        # the grid holds whole cells from the scene's lower corner: a point in the strip its
        # last cells leave at the upper edges (under a cell wide) takes the last cell
        cells = np.where(cells == np.array(grid.shape), cells - 1, cells)
        for p, c in zip(region.points, cells):
            if not grid.in_grid(c):
                span = grid.origin + np.array(grid.shape) * grid.cell_size
                raise ValueError(f"{what}: point {p.tolist()} lies outside the scene (its grid of "
                                 f"{grid.cell_size:.3g} m cells spans {np.round(grid.origin, 2).tolist()}-"
                                 f"{np.round(span, 2).tolist()})")
            if grid.occupancy[tuple(c)]:
                raise ValueError(f"{what}: the point {p.tolist()} lies in a grid cell an obstacle touches "
                                 f"(cell {tuple(int(x) for x in c)} of {grid.cell_size:.3g} m)")
        return cells
    centers = grid.all_centers().reshape(-1, grid.dim)
    inside = region.contains(centers) & (grid.occupancy.ravel() == 0)
    cells = np.stack(np.unravel_index(np.flatnonzero(inside), grid.shape), axis=1)
    if len(cells) == 0:
        lo, hi = grid.origin, grid.origin + np.array(grid.shape) * grid.cell_size
        box = region_box(region)
        if box is not None and (np.any(box[0] >= hi) or np.any(box[1] <= lo)):  # not in the scene: say so
            raise ValueError(f"{what}: {describe_region(region)} lies outside the scene: its grid of "
                             f"{grid.cell_size:.3g} m cells spans {np.round(lo, 2).tolist()}-"
                             f"{np.round(hi, 2).tolist()}")
        raise ValueError(f"{what}: {describe_region(region)} holds no grid cell free of obstacles "
                         f"(cell size {grid.cell_size:.3f} m)")
    return cells


def check_goal_room(groups: Sequence[Group], goal_cells: list[np.ndarray], cell: float) -> None:
    """A ValueError when agents that stay on arrival (one to a cell) outnumber the free
    cells of the goal area they share: the rest could never arrive, and the run would idle
    to max_steps. Groups on a route arrive where the route ends and are not counted."""
    sharing: dict = {}
    for k, g in enumerate(groups):
        if g.attributes.get("route") is None:
            key = frozenset(map(tuple, goal_cells[k].tolist()))
            sharing.setdefault(key, []).append(k)
    for key, ks in sharing.items():
        need = sum(groups[k].count for k in ks)
        if need > len(key):
            g = groups[ks[0]]
            who = f"{need} agents" if len(ks) == 1 else f"{need} agents of groups {', '.join(repr(groups[k].name) for k in ks)}"
            raise ValueError(f"group {g.name!r} goal: {describe_region(g.goal)} holds {len(key)} free grid cells of "
                             f"{cell:.3g} m{ONE_GRID} and agents stay on arrival, one to a cell: {who} cannot all "
                             f"arrive; enlarge the goal, lower the count or set [mdp] remove_on_arrival = true")


def spawn_cells(grid: GridMap, group: Group, taken: dict, rng: np.random.Generator,
                finest: float | None = None) -> np.ndarray:
    """Each agent's start cell; ``taken`` maps the cells given out so far to who holds
    them (the group's name and the point given, or None), and gets these. ``finest``: the
    smallest cell the bodies allow (the paper's rule), for the refusal's advice."""
    what = f"group {group.name!r} spawn"
    if isinstance(group.spawn, Lattice):
        raise ValueError(f"{what}: a lattice places bodies in continuous space, but the MDP method starts each agent "
                         f"on a free grid cell: give a rect (its free cells are drawn at random) or list the points")
    if isinstance(group.spawn, Points):
        if len(group.spawn.points) != group.count:
            raise ValueError(f"{what}: {len(group.spawn.points)} points given for {group.count} agents")
        cells = region_cells(grid, group.spawn, what)
        points = np.asarray(group.spawn.points, dtype=float)
    else:
        cand = region_cells(grid, group.spawn, what)
        cand = np.array([c for c in cand if tuple(c) not in taken])
        if len(cand) < group.count:
            raise ValueError(f"{what}: {describe_region(group.spawn)} has {len(cand)} free grid cells of "
                             f"{grid.cell_size:.3g} m{ONE_GRID} but count = {group.count} agents need one each: "
                             f"enlarge the spawn region or lower the count")
        cells = cand[rng.choice(len(cand), size=group.count, replace=False)]
        points = None
    for k, c in enumerate(cells):
        mine = (group.name, None if points is None else points[k])
        if tuple(c) in taken:
            raise ValueError(shared_cell_message(what, grid, c, taken[tuple(c)], mine, finest))
        taken[tuple(c)] = mine
    return cells


def shared_cell_message(what: str, grid: GridMap, cell, first: tuple, second: tuple, finest: float | None) -> str:
    """Why two start points that fall in one grid cell are refused, and what separates
    them: every agent starts on a cell centre, one to a cell, so points closer than a
    cell can share one (two robots 0.9 m apart did, in cells of 1.2 m)."""
    centre = grid.centers(cell)
    cell_m = grid.cell_size

    def who(name, point):
        if point is None:
            return f"a cell drawn from group {name!r}'s spawn area"
        return f"group {name!r} at {np.round(point, 3).tolist()}"

    head = (f"{what}: {who(*first)} and {who(*second)} fall in the same grid cell of {cell_m:.3g} m{ONE_GRID}, "
            f"centred at {np.round(centre, 3).tolist()}; the MDP method starts each agent on the centre of its "
            f"cell, one agent to a cell")
    if first[1] is None:  # (a spawn area's cells are drawn among those still free: only the first can be)
        return head + (f": keep group {second[0]!r}'s points out of group {first[0]!r}'s spawn area, or list "
                       f"group {second[0]!r} first")
    gap = float(np.max(np.abs(np.asarray(first[1]) - np.asarray(second[1]))))  # along the axis most apart
    if finest is None:
        return head + f": set a finer [mdp] cell_size (at most {gap:.3g} m) or place them at least a cell apart"
    rule = "sqrt(2) x the largest body's diameter, the paper's rule"
    if gap > finest:  # any cell of at most ``gap`` puts them in different cells
        return head + (f": set a finer [mdp] cell_size, between {finest:.3g} m ({rule}) and {gap:.3g} m (their "
                       f"largest offset along an axis), or place them at least a cell apart")
    return head + (f": they are {gap:.3g} m apart along an axis, closer than the finest cell the bodies allow, "
                   f"{finest:.3g} m ({rule}): place them further apart")


#: value of a cell a moving obstacle will cover soon, less the steps out of it: below any
#: field's value (a path of at most this many cells), so nobody steps in, but one standing in
#: it walks out the shortest way
ESCAPE_VALUE = -1e9


def obstacle_cells(static: GridMap, moving, step: int, chunk: int, lookahead: int,
                   dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(hard, occupied) 0/1 grids: ``hard``, the static obstacles and the cells the moving
    ones cover from ``step`` until the values are next solved, ``chunk`` steps on (nobody
    may stand there); ``occupied``, those and the cells they cover over the ``lookahead``
    steps after that (nobody should step in, but one already there walks out, see
    :func:`escape_values`)."""
    hard = GridMap(static.occupancy.copy(), static.cell_size, static.origin)
    for ob in moving:
        for k in range(chunk + 1):
            mark_obstacle(hard, ob, (step + k) * dt)
    occ = GridMap(hard.occupancy.copy(), static.cell_size, static.origin)
    for ob in moving:
        for k in range(chunk + 1, chunk + lookahead + 1):
            mark_obstacle(occ, ob, (step + k) * dt)
    return hard.occupancy, occ.occupancy


def escape_values(values: np.ndarray, occupied: np.ndarray, hard: np.ndarray) -> np.ndarray:
    """``values`` (F, *shape), solved with ``occupied`` blocked, with each cell of
    ``occupied`` that is not ``hard`` valued ESCAPE_VALUE less its steps (through such
    cells, diagonals included) to the nearest free cell: an agent that stepped in before
    the obstacle came into the look-ahead walks out before it arrives (the walker moves
    to a better-valued cell, and steps into none of these from a free one)."""
    from scipy.ndimage import binary_dilation, generate_binary_structure

    soft = (occupied != 0) & (hard == 0)
    if not soft.any():
        return values
    out = values.copy()
    reach = occupied == 0
    steps = np.full(occupied.shape, np.inf)
    around = generate_binary_structure(occupied.ndim, occupied.ndim)
    k = 0
    while True:
        k += 1
        ring = binary_dilation(reach, structure=around) & soft & ~reach
        if not ring.any():
            break
        steps[ring] = k
        reach |= ring
    out[:, soft] = np.where(np.isfinite(steps[soft]), ESCAPE_VALUE - steps[soft], -np.inf)
    return out


def solve_field(occupancy, goals, params: MDPParams, previous=None) -> np.ndarray:
    if params.solver == "vi" and previous is not None:  # warm start the paper's Algorithm 1
        return value_iteration(occupancy, [tuple(g) for g in goals], params.theta, params.corner_cutting,
                               init=previous)[0]
    return solve(occupancy, [tuple(g) for g in goals], params.solver, params.theta, params.corner_cutting)


@dataclass
class Setup:
    """What a run starts from: the grids, each group's goal cells (and the point they
    fill toward, for slots round a shared point), the agents' start cells and fields, and
    for groups that enter over time when and where each agent enters (``arrivals``; its
    start cell is then the one it is drawn to enter at)."""

    cell: float
    static: GridMap
    grid: GridMap
    goal_cells: list[np.ndarray]
    toward: list[np.ndarray | None]
    starts: np.ndarray
    field_of: np.ndarray
    arrivals: Arrivals | None = None


def setup(scene: Scene, groups: Sequence[Group], params: MDPParams, rng: np.random.Generator) -> Setup:
    """Rasterise, find goal cells and slots, place the agents: everything before stepping,
    so that a scenario check refuses exactly what a run would."""
    if not groups:
        raise ValueError("at least one group is needed")
    for g in groups:
        if g.dim != scene.dim:
            raise ValueError(f"group {g.name!r} is {g.dim}D but the scene is {scene.dim}D")
        if isinstance(g.goal, Points) and g.count > 1 and len(g.goal.points) == g.count:
            warnings.warn(f"group {g.name!r} goal: {g.count} points, one per agent: the MDP method takes a "
                          f"group's goal points as its goal cells, any agent to any free one (paper 000's group "
                          f"goal), not agent k to point k; for a goal per agent give each its own group",
                          stacklevel=2)
    cell = cell_size_for(groups, params)
    static = rasterise(scene, cell, moving=False)
    grid = rasterise(scene, cell, t=0.0)
    goal_cells = [region_cells(grid, g.goal, f"group {g.name!r} goal") for g in groups]
    # a point goal shared by more agents than it has points: the nearest free cells as slots
    toward = [None] * len(groups)
    for k, g in enumerate(groups):
        if isinstance(g.goal, Points) and len(goal_cells[k]) < g.count and not params.remove_on_arrival:
            toward[k] = goal_cells[k]
            try:
                goal_cells[k] = nearest_cells(grid.occupancy, goal_cells[k], g.count, params.corner_cutting)
            except ValueError as exc:
                raise ValueError(f"group {g.name!r} goal: {exc}") from None
    if not params.remove_on_arrival:
        check_goal_room(groups, goal_cells, cell)
    taken: dict = {}
    finest = min_cell_size(max(g.radius for g in groups))
    # groups entering over time take their cells one by one, when free (mdp.sources)
    cells = [None if "enter" in g.attributes else spawn_cells(grid, g, taken, rng, finest) for g in groups]
    arrivals = None
    if any(c is None for c in cells):
        arrivals = Arrivals(grid, groups, step_time(groups, params, cell, np.sqrt(grid.dim)), rng, region_cells)
        bounds = np.cumsum([0] + [g.count for g in groups])
        cells = [arrivals.first[bounds[k]:bounds[k + 1]] if c is None else c for k, c in enumerate(cells)]
    starts = np.concatenate(cells)
    field_of = np.repeat(np.arange(len(groups)), [g.count for g in groups])
    return Setup(cell, static, grid, goal_cells, toward, starts, field_of, arrivals)


def run(scene: Scene, groups: Sequence[Group], params: MDPParams, rng: np.random.Generator,
        progress: Callable[[int], None] | None = None) -> MDPRun:
    """Run the MDP method on a scene; ``progress(steps_done)`` is called after each chunk."""
    su = setup(scene, groups, params, rng)
    cell, static, grid, goal_cells, toward = su.cell, su.static, su.grid, su.goal_cells, su.toward
    starts, field_of, arrivals = su.starts, su.field_of, su.arrivals
    masks = []
    for gc in goal_cells:
        m = np.zeros(grid.shape, dtype=bool)
        m[tuple(gc.T)] = True
        masks.append(m)
    # moving obstacles are placed, and agents enter, at step * dt: fixed ahead for both
    dt = step_time(groups, params, cell, np.sqrt(grid.dim))
    r_cells = max(g.radius for g in groups) / cell
    walker = Walker(grid.occupancy, starts, masks, field_of, params.corner_cutting, min(r_cells, max_radius(1.0)),
                    present=None if arrivals is None else ~arrivals.later)
    moving = scene.moving_obstacles
    if any(g.attributes.get("route") is not None for g in groups):
        return _run_routes(scene, groups, params, rng, su, walker, dt, progress)
    values = None
    cells_out = [starts[None]]
    active_out = [np.ones((1, len(starts)), dtype=bool)]
    if arrivals is not None:  # those due at 0 come in at the first frame, as room allows
        arrivals.admit(walker, 0, rng)
        cells_out, active_out = [walker.cells[None]], [(walker.active == 1)[None]]
    done = 0
    # goal areas that keep their agents: latecomers are routed to the cells still free
    fill = not params.remove_on_arrival and not moving and any(len(gc) > 1 for gc in goal_cells)
    taken_before = None
    solved_at = 0  # the step the values were last solved at (moving obstacles placed from there on)
    reach: list = []

    def static_values() -> list:  # each field's values past the static obstacles alone, once needed
        if not reach:
            reach.extend(solve_field(static.occupancy, gc, params) for gc in goal_cells)
        return reach

    with step_loop() as loop:  # Ctrl-C: keep the steps so far, marked partial
        while done < params.max_steps:
            chunk = min(params.replan_every if moving or fill else 64, params.max_steps - done)
            if arrivals is not None:  # agents enter between chunks: end one at the next frame one may
                chunk = min(chunk, arrivals.steps_to_next(done))
            if values is None or moving:
                solved_at = done
                hard, occ = obstacle_cells(static, moving, done, chunk, params.lookahead, dt)
                prev = values
                values = np.stack([
                    solve_field(occ, [c for c in gc if not occ[tuple(c)]] or gc, params,
                                None if prev is None else prev[k])
                    for k, gc in enumerate(goal_cells)
                ])
                walker.set_blocked(hard)
                # Algorithm 3 follows v + the goal areas' fill depth (goal_fill: goals that fill)
                depth = np.stack([fill_depth(occ, gc, params.corner_cutting, toward[k])
                                  for k, gc in enumerate(goal_cells)])
                walker.set_values(escape_values(values, occ, hard) + depth)
            if fill:
                taken = walker.cells[walker.active == 1]
                key = taken.tobytes()
                if key != taken_before:
                    taken_before = key
                    walker.set_values(free_goal_values(occ, goal_cells, taken, values, params) + depth)
            before = walker.cells.copy()
            c, a = walker.advance(chunk, rng, params.tau, params.forbid_crossing, params.remove_on_arrival)
            cells_out.append(c)
            active_out.append(a)
            done += chunk
            if arrivals is not None and arrivals.pending:
                _admit(arrivals, walker, done, rng, c[-1], a[-1])
            if progress is not None:
                progress(done)
            if (params.stop_when_done and not moving and _all_settled(walker, masks, values)
                    and (arrivals is None or not arrivals.pending)
                    and (np.array_equal(before, walker.cells) or not walker.can_fill_deeper().any())):
                break
            if params.stop_when_done and moving and not (walker.active == 1).any() and (
                    arrivals is None or not arrivals.pending):
                break  # everyone has left: nobody for a moving obstacle to meet
            if (params.stop_when_done and moving and (arrivals is None or not arrivals.pending)
                    and _settled_for_good(walker, masks, values, static, moving, solved_at, dt, static_values,
                                          params.remove_on_arrival)):
                break  # everyone stays for good: the moving obstacles come near none of them again
    partial = loop.stopped
    n = min(len(cells_out), len(active_out))
    cells_out, active_out = cells_out[:n], active_out[:n]
    cells = np.concatenate(cells_out)
    active = np.concatenate(active_out)
    positions = held_absent(grid.centers(cells), active)
    # (agents entering over time keep the time base fixed ahead: their seconds map to steps)
    stretch = not moving and arrivals is None and params.smoothing == "relaxed" and params.speed_limited_steps
    if stretch:  # the relaxed paths' own top speed sets the time base (relaxed, below)
        dt = step_time(groups, params, cell, 1.0)
    elif not moving and arrivals is None and len(cells) > 1:  # the longest move actually made sets the step time
        made = np.abs(np.diff(cells, axis=0)).sum(axis=-1)[active[1:] & active[:-1]]
        dt = step_time(groups, params, cell, float(np.sqrt(made.max())) if made.size else 1.0)
    start_values = values[(field_of, *starts.T)] if values is not None else np.zeros(len(starts))
    unreachable = np.flatnonzero(~np.isfinite(start_values))
    radius = np.concatenate([np.full(g.count, g.radius) for g in groups])
    names = np.concatenate([np.full(g.count, g.name, dtype=object) for g in groups])
    traj = Trajectories(
        positions, dt, group=names, radius=radius, active=None if active.all() else active,
        metadata={"method": "mdp", "params": params.model_dump(), "cell_size": cell, "grid_shape": list(grid.shape),
                  "steps": int(len(cells) - 1), "unreachable_agents": unreachable.tolist(), "partial": partial,
                  "scene": scene.to_dict()},
    )
    max_speed = np.concatenate([np.full(g.count, g.max_speed) for g in groups])
    if params.smoothing == "relaxed":
        traj = relaxed(traj, params, scene, max_speed, stretch)
    elif params.smoothing is not None:
        traj = resample_checked(traj, params.fps, params.smoothing, scene, max_speed)
    return MDPRun(traj, grid, values, goal_cells, unreachable, field_of, arrivals=arrivals, walker=walker)


def _admit(arrivals: Arrivals, walker: Walker, frame: int, rng: np.random.Generator, cells: np.ndarray,
           active: np.ndarray) -> None:
    """Let in the agents due by ``frame`` that find a free cell, writing them into that
    frame's ``cells`` and ``active`` (the last row recorded)."""
    ids = arrivals.admit(walker, frame, rng)
    cells[ids] = walker.cells[ids]
    active[ids] = True


def _run_routes(scene: Scene, groups: Sequence[Group], params: MDPParams, rng: np.random.Generator, su: Setup,
                walker: Walker, dt: float, progress: Callable[[int], None] | None) -> MDPRun:
    """:func:`run` when a group has a route: one step of Algorithm 3 at a time, after
    each the route state machine moves agents on (:mod:`crowdmotion.mdp.routes`); the
    step time is fixed ahead (a diagonal within max_speed), so that waits last their
    seconds, and ``Trajectories.stage`` says each agent's stage per frame."""
    from crowdmotion._rng import step_key
    from crowdmotion.checks import where
    from crowdmotion.journeys import Journeys
    from crowdmotion.mdp.routes import MDPWalkers, check_mdp_route

    if scene.moving_obstacles:
        raise ValueError("mdp routes need a static scene: moving obstacles re-solve every field each few steps")
    routes = [g.attributes.get("route") for g in groups]
    for k, r in enumerate(routes):
        if r is not None:
            check_mdp_route(r, where(k, groups[k]))
    grid, starts, field_of = su.grid, su.starts, su.field_of.copy()  # each agent's group
    walker.field_of = walker.field_of.copy()  # the field each agent follows now: its stage's
    values = np.stack([solve_field(grid.occupancy, gc, params) for gc in su.goal_cells])
    depth = np.stack([fill_depth(grid.occupancy, gc, params.corner_cutting, su.toward[k])
                      for k, gc in enumerate(su.goal_cells)])
    walker.set_values(values + depth)
    on_route = np.array([routes[k] is not None for k in field_of], dtype=bool)
    walkers = MDPWalkers(walker, grid, params, dt, values, su.goal_cells, ~on_route & params.remove_on_arrival,
                         region_cells, solve_field)

    radius = np.concatenate([np.full(g.count, g.radius) for g in groups])
    pref = np.concatenate([np.full(g.count, g.pref_speed) for g in groups])
    journeys = Journeys(routes, field_of, [g.spawn for g in groups], radius, pref, step_key(rng), scene.clearance)
    arrivals = su.arrivals
    if arrivals is not None:  # those due at 0 come in at the first frame, as room allows (they begin their routes)
        arrivals.admit(walker, 0, rng)
    journeys.update(walkers, dt)
    cells_out = [walker.cells[None]]
    active_out = [(walker.active == 1)[None]]
    stages = [journeys.frame(active_out[0][0])]
    with step_loop() as loop:  # Ctrl-C: keep the steps so far, marked partial
        for done in range(1, params.max_steps + 1):
            before = walker.cells.copy()
            c, a = walker.advance(1, rng, params.tau, params.forbid_crossing, False)
            cells_out.append(c.copy())
            active_out.append(a)
            if arrivals is not None and arrivals.pending:  # they enter at the end of the step, and begin their routes
                _admit(arrivals, walker, done, rng, cells_out[-1][-1], a[-1])
            walkers.after_step()  # agents in their exit leave the scene; the rest move on
            journeys.update(walkers, dt)
            stages.append(journeys.frame(a[0]))
            if progress is not None:
                progress(done)
            if (params.stop_when_done and not journeys.busy(walkers.active) and walkers.settled()
                    and (arrivals is None or not arrivals.pending)
                    and (np.array_equal(before, walker.cells) or not walker.can_fill_deeper().any())):
                break
    partial = loop.stopped
    if not partial and (active_out[-1][-1] & ~walkers.active).any():  # the last to leave, gone in a frame more
        cells_out.append(walker.cells[None])
        active_out.append(walkers.active[None])
        stages.append(journeys.frame(walkers.active))
    n = min(len(cells_out), len(active_out), len(stages))
    cells = np.concatenate(cells_out[:n])
    active = np.concatenate(active_out[:n])
    stage = np.array(stages[:n])
    unreachable = np.flatnonzero(~np.isfinite(values[(field_of, *starts.T)]))
    names = np.concatenate([np.full(g.count, g.name, dtype=object) for g in groups])
    traj = Trajectories(
        held_absent(grid.centers(cells), active), dt, group=names, radius=radius,
        active=None if active.all() else active, stage=stage,
        metadata={"method": "mdp", "params": params.model_dump(), "cell_size": su.cell, "grid_shape": list(grid.shape),
                  "steps": int(len(cells) - 1), "unreachable_agents": unreachable.tolist(), "partial": partial,
                  "scene": scene.to_dict(), "stages": journeys.stage_table([g.name for g in groups]),
                  "route_fields_solved": walkers.solves},
    )
    max_speed = np.concatenate([np.full(g.count, g.max_speed) for g in groups])
    if params.smoothing == "relaxed":
        out = relaxed(traj, params, scene, max_speed, False)
    elif params.smoothing is not None:
        out = resample_checked(traj, params.fps, params.smoothing, scene, max_speed)
    else:
        out = traj
    if out is not traj:  # each new frame holds the stage of the step it ends in (as resample does)
        out.stage = held_stages(stage, out.times, dt, out.active_mask)
    return MDPRun(out, grid, values, su.goal_cells, unreachable, field_of, journeys, walkers, arrivals, walker)


# The relaxed paths settle with up to this many rounds of pushes alone, each agent within
# its speed, as PSO's do: without, 150 people leaving a room by a 1.2 m door kept the plan's
# straight moves on 10 % of their steps (each step put back, or too fast, brought the
# bodies beside it together in turn), and the walkers in the queue turned and stopped as
# the plan does (p95 acceleration 6.3 m/s² at 24 fps; 1.4 m/s² settled)
RELAX_SETTLE = 20


def relaxed(traj: Trajectories, params: MDPParams, scene: Scene, max_speed: np.ndarray,
            stretch: bool = False) -> Trajectories:
    """The run's paths at ``params.fps``, relaxed (``crowdmotion.path_relaxation``: smoothed
    over ``smoothing_window`` seconds, bodies kept apart and out of the obstacles, settled
    with up to ``RELAX_SETTLE`` rounds of pushes, each agent within its speed), then
    audited in continuous time: a step where they still touch, or outrun ``max_speed``,
    keeps the plan's straight move (``crowdmotion.smoothing.keep_clean``); a
    run with more than ``RELAX_AT_FPS_MAX`` agent-frames at ``fps`` is relaxed at its own
    steps (:func:`crowdmotion.path_relaxation.relaxed_trajectories`).

    ``stretch`` (static scenes with ``speed_limited_steps``): the run steps a cell per
    cell / pref_speed, and where its relaxed paths run faster than an agent's max_speed (a
    run of diagonal moves: √2 cells a step), the whole run is slowed by that factor before
    the audit: every path and all their timings are kept, and no agent pays
    for a diagonal it did not make by going slower on its straight moves."""
    return relaxed_trajectories(traj, params.fps, params.smoothing_window, scene, max_speed, settle=RELAX_SETTLE,
                                keep_speed=True, stretch=stretch)


def free_goal_values(occupancy: np.ndarray, goal_cells: list[np.ndarray], taken: np.ndarray, values: np.ndarray,
                     params: MDPParams) -> np.ndarray:
    """Each group's values toward the goal cells nobody stands on (goal_fill: goals that
    fill). A goal area keeps its agents, so a cell taken is taken for good: without this,
    a latecomer whose side of the area is full can only random-walk round its rim (in
    mdp_diversity one robot circled a full goal disc for 130 steps). Taken goal cells are
    walls for this solve and keep their value 0, so agents inside still fill deeper by
    depth alone; groups whose goal cells are all taken, or none, keep ``values``."""
    out = values.copy()
    busy = np.zeros(occupancy.shape, dtype=bool)
    busy[tuple(np.asarray(taken, dtype=np.int64).T)] = True
    for k, gc in enumerate(goal_cells):
        on = busy[tuple(gc.T)]
        if not on.any() or on.all() or len(gc) < 2:
            continue
        occ = occupancy.copy()
        occ[tuple(gc[on].T)] = 1
        free = [tuple(c) for c in gc[~on] if not occupancy[tuple(c)]]
        if not free:
            continue
        v = solve_field(occ, free, params)
        v[tuple(gc[on].T)] = 0.0
        out[k] = v
    return out


def _settled_for_good(walker: Walker, masks, values: np.ndarray, static: GridMap, moving, since: int, dt: float,
                      static_values: Callable[[], list], leave: bool) -> bool:
    """With moving obstacles: whether nothing can move anyone any more (a goal area keeps
    its agents, and a run went on to max_steps with nobody moving: 373 s of frames, the
    last move at 55 s).

    Once every path has ended before ``since`` (the step the current ``values`` were
    solved at, every obstacle then placed where it stays), the scene is static and the
    static rule holds: every agent on a goal cell with no free, deeper goal cell next to
    it, or unable to reach one. Before: every agent stands on such a goal cell, or cannot
    reach its goal past the static obstacles alone (``static_values()``: each field's
    values there; the moving ones only close more ways), and no moving obstacle, placed at
    each step from ``since`` until its path has ended, covers a cell of their goal areas,
    a stuck agent's cell, or a cell next to one of those. Those cells and their neighbours
    are all that the agents' moves, the goal areas' fill depth and the walk out of a cell
    an obstacle comes to read, so every later solve leaves them as they are. ``leave``
    (``remove_on_arrival``): an agent on a goal cell is not settled but leaving."""
    from scipy.ndimage import binary_dilation

    on = walker.active == 1
    if not on.any():
        return True
    cells, field = walker.cells[on], walker.field_of[on]
    masks = np.asarray(masks)
    at_goal = masks[(field, *cells.T)]
    if leave and at_goal.any():
        return False  # they leave at their next turn
    end = max(float(ob.path.times[-1]) for ob in moving)  # each stands at its last key position after
    if since * dt >= end:
        return _all_settled(walker, masks, values) and not walker.can_fill_deeper().any()
    stuck = np.zeros(len(cells), dtype=bool)
    if not at_goal.all():
        stuck = ~at_goal & ~np.isfinite(np.stack(static_values())[(field, *cells.T)])
        if not (at_goal | stuck).all():
            return False
    if walker.can_fill_deeper().any():
        return False
    watch = np.zeros(static.shape, dtype=bool)
    for f in np.unique(field[at_goal]):
        watch |= masks[f]
    watch[tuple(cells[stuck].T)] = True
    watch = binary_dilation(watch, structure=np.ones((3,) * static.dim, dtype=bool))
    covered = GridMap(np.zeros(static.shape, dtype=np.uint8), static.cell_size, static.origin)
    for ob in moving:
        for k in range(since, max(since, int(np.ceil(end / dt))) + 1):
            mark_obstacle(covered, ob, k * dt)
    return not (covered.occupancy.astype(bool) & watch).any()


def _all_settled(walker: Walker, masks, values) -> bool:
    """Every agent despawned, on a goal cell, or unable to reach one."""
    cells = walker.cells
    for i, c in enumerate(cells):
        if not walker.active[i]:
            continue
        f = walker.field_of[i]
        if not masks[f][tuple(c)] and np.isfinite(values[f][tuple(c)]):
            return False
    return True


def simulate(scene: Scene, groups: Sequence[Group], params: MDPParams | None = None,
             rng: np.random.Generator | None = None, progress: bool = False) -> Trajectories:
    """The MDP method's entry point: ``simulate(scene, groups, params, rng) -> Trajectories``;
    ``progress=True`` shows the command's bar of steps on stderr (a line every 10 s where
    that is not a terminal), which says so while the kernels load, or compile on a first
    run (``crowdmotion.progress.step_bar``; as every method's ``simulate``).

    Agents stand and move on grid cell centres (paper 000), so each start and goal point
    is moved to the centre of its cell, by up to half a cell's diagonal (cell_size · √D / 2:
    0.60 m in the default cells of 0.3 m robots, 0.85 m; ``metadata["cell_size"]`` gives
    the cell used). The first and last frames are those centres, not the points given:
    for exact poses give points that are cell centres (``origin + (cell_of(p) + 0.5) ·
    cell_size`` of ``rasterise(scene, cell_size)``, origin the scene's lower bound), or
    shrink the error with a smaller ``params.cell_size`` (over √2 × the largest body's
    diameter). Two start points in one cell are refused, naming the cell size and the
    finer cells that would part them (docs/mdp.md, "Starts and goals sit on cell centres")."""
    params = MDPParams() if params is None else params
    rng = np.random.default_rng() if rng is None else rng
    with step_bar(params.max_steps, "mdp steps", progress) as bar:
        traj = run(scene, groups, params, rng, progress=bar.done).trajectories
    stranded = traj.metadata.get("unreachable_agents") or []
    if stranded:  # as a scenario's check refuses: said here, where nothing refuses it
        warnings.warn(f"{len(stranded)} agent(s) (e.g. {stranded[0]}) cannot reach their goal on the grid: walls "
                      f"close the way for their bodies; they stand where they started (metadata "
                      f"'unreachable_agents')", stacklevel=2)
    return traj
