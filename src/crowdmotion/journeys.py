"""Journeys, shared by the methods: when the agents of a group enter the scene (sources),
and where each agent on a route is (its stage, and the events that move it on).

A group may enter over time instead of all at once: at a rate, or at listed times. In a
scenario file::

    [[groups]]
    name = "commuters"
    count = 120
    spawn = { shape = "rect", lower = [0, 4], upper = [1, 8] }   # the entrance
    goal = { shape = "rect", lower = [38, 2], upper = [40, 10] }
    enter = { rate = 2.0, start = 5.0 }     # 2 persons/s from t = 5 s: the last at 64.5 s
    # enter = { times = [0, 0.5, 3, ...] }  # or one time per agent, seconds

and in Python ``Group(..., attributes={"enter": {"rate": 2.0}})``. Each agent gets a point
of the spawn region; when its time comes it enters there if no one stands within its body
of it, else it waits off-scene (not drawn, not avoided) and tries a fresh point of the
region at each step until there is room. The delay (entry time less the time it was due)
is reported per group. Without ``enter`` every agent starts at t = 0.

``end`` closes the window: with a rate the whole group must fit in it, without one the
group is spread evenly over [start, end]. ``entrances = [areas]`` (with optional
``weights``) replace the spawn: each entrance takes its share of the group (exact to one
agent, in an order drawn from the seed) and each agent enters at a point of its own; the
delay is then reported per entrance too.

A group may also follow a *route* of stages (:mod:`crowdmotion.stages`): go to an area,
wait, queue, choose among next stages, leave. :class:`Journeys` is the state machine that
walks the agents along their routes: after each step of a method it reads who has
arrived where and the time, and gives the agents whose stage changed their new goals
through the method's own goal API (``set_goals``, as :class:`crowdmotion.rvo.Simulator`
has it). Work per step is a few array operations over the agents, and Python only for
the agents whose stage changes.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Protocol

import numpy as np

from crowdmotion._rng import uniforms
from crowdmotion.cases import flow, stationary
from crowdmotion.geometry import finite_number
from crowdmotion.groups import Disc, Points, Rect
from crowdmotion.placement import spawn_positions
from crowdmotion.queues import ServiceQueue, wait_row
from crowdmotion.stages import Choose, GoTo, Leave, Queue, RouteMap, Wait, check_route, route_map

ENTER_KEYS = ("rate", "start", "end", "times", "entrances", "weights")


def entry_times(spec, count: int, where: str = "enter") -> np.ndarray:
    """(count,) the time (s) each agent of a group is due to enter; zeros without a spec.

    ``start`` alone: every agent is due then (they come in as room allows).
    ``rate`` (persons/s) from ``start`` (s, default 0): ``start + k / rate`` for k = 0 …
    count − 1; with an ``end`` (s) too, the window must hold them all (count ≤
    floor(rate·(end − start)) + 1). ``end`` without a rate spreads the group evenly over
    [start, end], the first at start and the last at end. ``times``: one absolute time
    per agent. ValueError naming ``where``'s field and the bad value otherwise."""
    if spec is None:
        return np.zeros(count)
    if not isinstance(spec, dict):
        raise ValueError(f"{where} must be a table: rate (persons/s), start and end (s), or times (s), got {spec!r}")
    unknown = sorted(set(spec) - set(ENTER_KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; expected rate, start and end, or times "
                         f"(and entrances with their weights)")
    timed = "rate" in spec or "end" in spec or "start" in spec
    if timed == ("times" in spec):
        raise ValueError(f"{where}: give either rate (with an optional start and end), start and end, or times, "
                         f"got {_shown_times(spec)}")
    if "times" in spec:
        if "start" in spec:
            raise ValueError(f"{where}: start goes with rate or end; times are absolute, got {_shown_times(spec)}")
        try:
            times = np.asarray(spec["times"], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{where}.times must be a list of seconds, got {spec['times']!r}") from None
        if times.shape != (count,):
            raise ValueError(f"{where}.times: {times.size} time(s) for a group of {count}: give one per agent")
        bad = np.flatnonzero(~np.isfinite(times) | (times < 0))
        if len(bad):
            raise ValueError(f"{where}.times.{int(bad[0])} must be a number of seconds >= 0, got {times[bad[0]]}")
        return times
    start = _number(spec.get("start", 0.0), f"{where}.start")
    end = None if "end" not in spec else _number(spec["end"], f"{where}.end")
    if end is not None and end <= start:
        raise ValueError(f"{where}.end must be after start ({start:g} s), got {end:g}")
    if "rate" not in spec and end is None:  # all due at start
        return np.full(count, start)
    if "rate" not in spec:  # spread evenly over [start, end]
        return start + np.arange(count) * ((end - start) / max(count - 1, 1))
    rate = _number(spec["rate"], f"{where}.rate")
    if rate <= 0:
        raise ValueError(f"{where}.rate must be a positive number of persons per second, got {spec['rate']!r}")
    times = start + np.arange(count) / rate
    if end is not None and times[-1] > end + 1e-9:
        fit = int(np.floor((end - start) * rate + 1e-9)) + 1
        raise ValueError(f"{where}.end: {count} agents at {rate:g} persons/s from {start:g} s need until "
                         f"{times[-1]:g} s, after end = {end:g} s: the window holds {fit}; lower the count, "
                         f"raise the rate to {(count - 1) / (end - start):g} or move end to {times[-1]:g}")
    return times


def entrances(spec, where: str = "enter") -> tuple[list, np.ndarray] | None:
    """A group's entrances and the share of the group each takes (weights summing to 1),
    or None when it enters at its spawn. ValueError naming ``where``'s field otherwise."""
    if not isinstance(spec, dict) or ("entrances" not in spec and "weights" not in spec):
        return None
    if "entrances" not in spec:
        raise ValueError(f"{where}.weights: weights go with entrances, one per entrance")
    areas = spec["entrances"]
    if not isinstance(areas, (list, tuple)) or not areas:
        raise ValueError(f"{where}.entrances must be a list of areas (point, points, rect or disc), got {areas!r}")
    for i, a in enumerate(areas):
        if not isinstance(a, (Points, Rect, Disc)):
            raise ValueError(f"{where}.entrances.{i} must be an area (point, points, rect or disc), got {a!r}")
    w = spec.get("weights", [1.0] * len(areas))
    try:
        w = np.asarray(w, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{where}.weights must be a list of numbers, got {spec['weights']!r}") from None
    if w.shape != (len(areas),):
        raise ValueError(f"{where}.weights: {w.size} weight(s) for {len(areas)} entrance(s): give one per entrance")
    if not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise ValueError(f"{where}.weights must be finite numbers >= 0, not all 0, got {w.tolist()}")
    return list(areas), w / w.sum()


def entrance_areas(spec, where: str = "enter") -> list:
    """A group's entrance areas ([] when it enters at its spawn); see :func:`entrances`."""
    got = entrances(spec, where)
    return [] if got is None else got[0]


def check_enter(spec, count: int, where: str = "enter") -> None:
    """Refuse an ``enter`` table a group of ``count`` cannot use (ValueError naming the
    field): its times and its entrances."""
    entry_times(spec, count, where)
    entrances(spec, where)


def entrance_of(spec, count: int, rng: np.random.Generator, where: str = "enter") -> np.ndarray | None:
    """(count,) the entrance each agent enters at (an index into ``entrances``), None
    without entrances: each entrance takes its share of the group (largest remainders,
    so the shares are exact up to one agent), in an order drawn from ``rng``."""
    got = entrances(spec, where)
    if got is None:
        return None
    share = got[1] * count
    quota = np.floor(share).astype(np.int64)
    quota[np.argsort(quota - share, kind="stable")[:count - int(quota.sum())]] += 1
    return rng.permutation(np.repeat(np.arange(len(quota)), quota))


def entry_points(scene, group, doors: np.ndarray, gap: float, rng: np.random.Generator) -> np.ndarray:
    """(len(doors), dim) where agents of ``group`` entering over time come in: for each,
    a point of its entrance (``doors``: indices into ``enter.entrances``; -1: the spawn),
    ``gap`` metres clear of obstacles. Bodies may overlap here: they come in one by one,
    each when its place is free. A points area gives each one of its points, drawn (a
    points spawn: the listed point of each agent, kept)."""
    doors = np.asarray(doors, dtype=np.int64)
    areas = entrance_areas(group.attributes.get("enter"))
    out = np.empty((len(doors), scene.dim))
    for j in np.unique(doors):
        own = doors == j
        area = group.spawn if j < 0 else areas[j]
        if isinstance(area, Points) and j >= 0:
            out[own] = area.points[rng.integers(len(area.points), size=int(own.sum()))]
        else:
            out[own] = spawn_positions(scene, replace(group, spawn=area, count=int(own.sum())),
                                       np.zeros((0, scene.dim)), np.zeros(0), gap, rng, overlap=True)
    return out


def unit_entry_time(spec, where: str = "enter", unit: str = "a formation") -> float:
    """When a group that enters as one unit (``unit``: a formation, a PSO swarm) is due:
    ``enter = { start = s }`` (default 0); ValueError naming the field for anything else
    (a rate, an end, times, entrances: a unit cannot come in over time or by several
    doors)."""
    if spec is None:
        return 0.0
    if isinstance(spec, dict):
        other = [k for k in spec if k != "start"]
        if other:
            raise ValueError(f"{where}.{other[0]}: {unit} enters as one unit, all at once at its spawn: "
                             f"give enter = {{ start = s }} only")
        spec = {"start": spec.get("start", 0.0)}
    return float(entry_times(spec, 1, where)[0])


def _shown_times(spec: dict) -> dict:
    """The spec's timing keys (for a message: entrances are region objects)."""
    return {k: v for k, v in spec.items() if k not in ("entrances", "weights")}


def _number(value, where: str) -> float:
    if not finite_number(value) or value < 0:
        raise ValueError(f"{where} must be a finite number >= 0, got {value!r}")
    return float(value)


def entry_report(names: np.ndarray, due: np.ndarray, entered: np.ndarray, entrance: np.ndarray | None = None) -> dict:
    """Per group: agents that entered, agents still waiting at the end, and the mean and
    longest delay (s) between being due and entering (for summary.json); for a group
    with entrances (``entrance``: (N,) index, -1 none), the same per entrance, in order."""
    def row(own: np.ndarray) -> dict:
        ok = own & np.isfinite(entered)
        delay = entered[ok] - due[ok]
        return {"entered": int(ok.sum()), "waiting_at_end": int((own & ~np.isfinite(entered)).sum()),
                "mean_delay_s": float(delay.mean()) if ok.any() else None,
                "max_delay_s": float(delay.max()) if ok.any() else None}

    out = {}
    for name in dict.fromkeys(names.tolist()):
        own = names == name
        out[str(name)] = row(own)
        doors = np.array([]) if entrance is None else entrance[own]
        if (doors >= 0).any():
            out[str(name)]["entrances"] = [row(own & (entrance == j)) for j in range(int(doors.max()) + 1)]
    return out


# ---- routes ---------------------------------------------------------------------------
FREE_POINT_TRIES = 32   # candidate points an agent tries for a free point of an area
FREE_POINT_GAP_M = 0.1  # clearance between two bodies standing at free points
FREE_POINT_WALL_GAP_M = 0.25  # clearance between a body at a free point and an obstacle
DRAW_CHOICE, DRAW_FREE_POINT, DRAW_SHARE = 1 << 20, 1 << 21, 1 << 22  # draw numbers (per stage id) of each kind


class Walkers(Protocol):
    """What :class:`Journeys` reads from and asks of a stepping method (the RVO simulator
    has all of it): where its agents are, who is in the scene, who has reached its goal,
    the time, and goals to set."""

    positions: np.ndarray
    active: np.ndarray
    time: float

    @property
    def arrived(self) -> np.ndarray: ...

    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere: bool = False,
                  leave: bool | None = None) -> None: ...

    def walking_distance(self, points, region) -> np.ndarray: ...

    def add_goal_regions(self, regions) -> None: ...


class Journeys:
    """Where each agent on a route is, and the goals that move it on.

    Parameters
    ----------
    routes : list
        Per group, its route (a list of stages) or None.
    group_of : (N,) int
        Each agent's group (an index into ``routes``).
    spawns : list
        Per group, its spawn region: where an agent whose route starts with a wait stands.
    radius, pref_speed : (N,) float
        Bodies (free points keep them apart) and walking speeds (least-crowded choices
        weigh walking times).
    key : int
        The run's key for its draws (waiting times, weighted choices, free points):
        the same key gives the same draws, agent by agent (:mod:`crowdmotion._rng`).
    clearance : callable, optional
        ``clearance(points)`` -> metres to the nearest obstacle or wall, so that free
        points leave room for a body.

    Attributes
    ----------
    stage : (N,) int
        Each agent's stage id now (:func:`crowdmotion.stages.flat_stages`), -1 off route
        or before it enters.
    """

    def __init__(self, routes, group_of, spawns, radius, pref_speed, key, clearance=None):
        self.routes = [None if r is None else check_route(r, f"groups.{g}.route") for g, r in enumerate(routes)]
        self.maps: list[RouteMap | None] = [None if r is None else route_map(r) for r in self.routes]
        self.flat = [[] if m is None else m.stages for m in self.maps]
        self.group_of = np.asarray(group_of, dtype=np.int64)
        n = len(self.group_of)
        self.spawns = list(spawns)
        self.radius = np.asarray(radius, dtype=float)
        self.pref_speed = np.asarray(pref_speed, dtype=float)
        self.key = np.uint64(key)
        self.clearance = clearance
        self.on_route = np.array([self.routes[g] is not None for g in self.group_of], dtype=bool)
        self.stage = np.full(n, -1, dtype=np.int64)
        self.begun = np.zeros(n, dtype=bool)
        self.done = np.zeros(n, dtype=bool)
        self.expect = np.zeros(n, dtype=bool)       # walking to a stage's place: arriving moves it on
        self.wait_until = np.full(n, np.inf)
        self.finished_at = np.full(n, np.nan)      # when each agent left or reached its route's end
        width = max([len(f) for f in self.flat] + [1])
        self.since = np.full((n, width), np.nan)    # when each agent began each stage
        self.reached = np.full((n, width), np.nan)  # when it reached the stage's place (joined, left)
        self.until = np.full((n, width), np.nan)    # when it moved on
        # queues shared by every group that names the same one; places for all who may queue
        self.queues: list[ServiceQueue] = []
        self._queue_of: dict = {}
        places: dict = {}
        for g, f in enumerate(self.flat):
            count = int(np.sum(self.group_of == g))
            for _, st, _ in f:
                if isinstance(st, Queue):
                    places[st.key] = places.get(st.key, 0) + count
        first: dict = {}
        for f in self.flat:
            for _, st, _ in f:
                if isinstance(st, Queue):
                    first.setdefault(st.key, st)
        for key, st in first.items():
            self._add_queue(st, places[key])
        self.bound: dict[int, int] = {}             # id(goto/leave stage) -> agents bound there
        self.held: dict[int, dict[int, np.ndarray]] = {}  # id(area) -> {agent: its free point}
        self.holder = np.full(n, -1, dtype=np.int64)  # the id(area) whose free point each agent holds (-1: none)
        self.exits: dict[str, list[float]] = {}     # exit name -> when each agent left by it
        self.exit_agents: dict[str, list[int]] = {}  # exit name -> who, in the same order
        self.removed = np.zeros(n, dtype=bool)    # taken out of the scene while on their route
        self.left = np.zeros(n, dtype=bool)       # finished their route by a leave stage
        self.chooser = np.full(n, -1, dtype=np.int64)  # the choose stage (id) whose option each re-weighs (-1: none)
        self.recheck_at = np.full(n, np.inf)       # when it next re-weighs that choice (Choose.rechoose)
        self._rechoosing = False                   # whether any agent ever entered a choose with rechoose
        self.chosen: dict[tuple[int, int], np.ndarray] = {}  # (group, choose's stage id) -> agents per option
        # (group, leave stage id that is an option of a choose) -> (the choose's stage id, its
        # option index, [(option index, leave stage id) of the choose's other leave options])
        self._sibling_exits: dict[tuple[int, int], tuple[int, int, list]] = {}
        for g, m in enumerate(self.maps):
            for sid, heads in ({} if m is None else m.options).items():
                exits = [(j, h) for j, h in enumerate(heads) if isinstance(m.stages[h][1], Leave)]
                for j, h in exits:
                    self._sibling_exits[(g, h)] = (sid, j, [(k, o) for k, o in exits if o != h])
        self._share_of: dict[tuple[int, int], np.ndarray] = {}  # (group, weighted choose's id) -> option per agent
        self.time = 0.0

    # ---- routes set while running (the live API) ----------------------------------------
    def set_route(self, agents, route, w: Walkers, radius=None, pref_speed=None, check=None) -> None:
        """Send ``agents`` along ``route`` (a list of stages) from now on, wherever they
        are on their old route: they leave its stage (a queue's line closes up behind
        them, a held free point is freed) and begin the new route's first stage; agents
        not yet in the scene begin it when they enter. Agents added to ``w`` since are
        taken on (``radius`` and ``pref_speed``: (N,) over all of ``w``'s agents).

        ``check(route)``, when given, refuses a route whose places do not fit the scene
        (ValueError naming the stage, as a scenario's are refused) before anything
        changes."""
        route = check_route(route, "route")
        n = len(w.active)
        ids = np.unique(np.asarray(agents, dtype=np.int64).ravel())
        if len(ids) and (ids.min() < 0 or ids.max() >= n):
            raise ValueError(f"set_route: agent ids must be in [0, {n}), got {ids.tolist()}")
        if check is not None:
            check(route, ids)
        self._take_on(n, radius, pref_speed)
        g = len(self.routes)
        links = route_map(route)
        flat = links.stages
        self.routes.append(route)
        self.maps.append(links)
        self.flat.append(flat)
        self.spawns.append(None)
        if len(flat) > self.since.shape[1]:
            more = np.full((n, len(flat) - self.since.shape[1]), np.nan)
            self.since, self.reached, self.until = (np.hstack([a, more]) for a in (self.since, self.reached, self.until))
        for _, st, _ in flat:
            if isinstance(st, Queue):
                self._add_queue(st, len(ids))
        w.add_goal_regions(self.regions())
        self._drop(ids[self.on_route[ids] & self.begun[ids] & ~self.done[ids]], w)
        self.group_of[ids] = g
        self.on_route[ids] = True
        self.done[ids] = self.removed[ids] = self.left[ids] = False
        self.stage[ids] = -1
        self.finished_at[ids] = np.nan
        for a in (self.since, self.reached, self.until):
            a[ids] = np.nan
        inside = ids[w.active[ids]]
        self.begun[ids] = False
        self.begun[inside] = True
        self.time = float(w.time)
        if len(inside):
            self._enter_at(inside, np.zeros(len(inside), dtype=np.int64), w)

    def _take_on(self, n: int, radius=None, pref_speed=None) -> None:
        """Grow the per-agent arrays to ``n`` agents (added to the method since), off route."""
        k = n - len(self.group_of)
        if radius is not None:
            self.radius = np.asarray(radius, dtype=float).copy()
        if pref_speed is not None:
            self.pref_speed = np.asarray(pref_speed, dtype=float).copy()
        if k <= 0:
            return
        if not any(r is None for r in self.routes):
            self.routes.append(None)
            self.maps.append(None)
            self.flat.append([])
            self.spawns.append(None)
        off = next(g for g, r in enumerate(self.routes) if r is None)
        width = self.since.shape[1]
        self.group_of = np.append(self.group_of, np.full(k, off))
        for name, fill, dtype in (("stage", -1, np.int64), ("holder", -1, np.int64),
                                  ("chooser", -1, np.int64), ("on_route", False, bool), ("begun", False, bool),
                                  ("done", False, bool), ("expect", False, bool), ("removed", False, bool),
                                  ("left", False, bool),
                                  ("wait_until", np.inf, float), ("recheck_at", np.inf, float),
                                  ("finished_at", np.nan, float)):
            setattr(self, name, np.append(getattr(self, name), np.full(k, fill, dtype=dtype)))
        for name in ("since", "reached", "until"):
            setattr(self, name, np.vstack([getattr(self, name), np.full((k, width), np.nan)]))

    def _add_queue(self, st: Queue, places: int) -> None:
        """Lay out ``places`` more places in the queue ``st`` names, making it on first
        mention (groups naming the same queue share it)."""
        if st.key in self._queue_of:
            self.queues[self._queue_of[st.key]].grow(places)
        else:
            self._queue_of[st.key] = len(self.queues)
            self.queues.append(ServiceQueue(st, places))

    def _drop(self, ids: np.ndarray, w: Walkers) -> None:
        """Agents ``ids`` leave the stage they are in (rerouted or taken out of the scene):
        no longer bound to its area, out of its queue (the line closes up), their free
        point freed, no wait running."""
        if not len(ids):
            return
        for a in ids:
            g, sid = int(self.group_of[a]), int(self.stage[a])
            st = self.flat[g][sid][1] if 0 <= sid < len(self.flat[g]) else None
            if isinstance(st, (GoTo, Leave)) and self.expect[a]:
                self.bound[id(st)] -= 1
        for q in self.queues:
            if q.remove(ids):  # its line closes up; a queue that lost nobody from it keeps its goals
                self._close_up(q, w)
        self.expect[ids] = False
        self.wait_until[ids] = np.inf
        self.chooser[ids] = -1
        self.recheck_at[ids] = np.inf
        self._release_points(ids)

    # ---- what the method needs before it starts -------------------------------------
    def regions(self) -> list:
        """Every region agents may be sent to (areas, queue lines, spawns where routes
        start with a wait), so the method can solve their guidance fields up front."""
        out = []

        def add(r):
            if isinstance(r, (Rect, Disc, Points)) and all(x is not r for x in out):
                out.append(r)

        for g, f in enumerate(self.flat):
            for _, st, _ in f:
                add(st.area if isinstance(st, (GoTo, Leave)) else None)
                if isinstance(st, Queue):
                    add(self.queues[self._queue_of[st.key]].region)
            if any(isinstance(st, Wait) and self.maps[g].hold[sid] for sid, (_, st, _) in enumerate(f)):
                add(self.spawns[g])
        return out

    def busy(self, active: np.ndarray) -> bool:
        """Whether an agent in the scene is still on its way along its route."""
        return bool(np.any(self.on_route & self.begun & ~self.done & active))

    def frame(self, present: np.ndarray) -> np.ndarray:
        """(N,) int16 stage ids for a frame: -1 for agents not drawn in it."""
        return np.where(present, self.stage, -1).astype(np.int16)

    # ---- the step ---------------------------------------------------------------------
    def update(self, w: Walkers, dt: float) -> None:
        """Move agents on after a step of the method ``w``: those that entered begin
        their routes, those that arrived, finished waiting or were served go on to their
        next stage (new goals through ``w.set_goals``)."""
        self.time = t = float(w.time)
        if len(w.active) > len(self.group_of):
            self._take_on(len(w.active))
        new = self.on_route & ~self.begun & w.active
        if new.any():
            ids = np.flatnonzero(new)
            self.begun[ids] = True
            self._enter_at(ids, np.zeros(len(ids), dtype=np.int64), w)
        if self._sibling_exits:
            self._leave_where_they_stand(w)
        arrived = self.expect & w.arrived
        if arrived.any():
            self._arrive(np.flatnonzero(arrived), w)
        gone = self.on_route & self.begun & ~self.done & ~w.active  # taken out of the scene by the caller
        if gone.any():
            ids = np.flatnonzero(gone)
            self._drop(ids, w)
            self.done[ids] = self.removed[ids] = True
        over = self.wait_until <= t + 1e-9
        if over.any():
            ids = np.flatnonzero(over)
            self.wait_until[ids] = np.inf
            self._next(ids, w)
        if self._rechoosing:
            due = self.recheck_at <= t + 1e-9
            if due.any():
                self._rechoose(np.flatnonzero(due), w)
        for q in self.queues:
            self._serve(q, w)
            q.sample(t, dt)

    def _enter_at(self, ids: np.ndarray, sids: np.ndarray, w: Walkers) -> None:
        """Agents ``ids`` begin stages ``sids`` (stage ids) of their routes; a stage id
        past the route's last means the route is done."""
        for g in np.unique(self.group_of[ids]):
            for sid in np.unique(sids[self.group_of[ids] == g]):
                sub = ids[(self.group_of[ids] == g) & (sids == sid)]
                if sid >= len(self.flat[g]):  # the route is done: they stay where they are
                    self.done[sub] = True
                    self.finished_at[sub] = self.time
                    continue
                self._enter(sub, int(g), int(sid), w)

    def _enter(self, ids: np.ndarray, g: int, sid: int, w: Walkers) -> None:
        st = self.flat[g][sid][1]
        t = self.time
        self.stage[ids] = sid
        self.since[ids, sid] = t
        self.expect[ids] = False
        self.chooser[ids] = -1
        self.recheck_at[ids] = np.inf
        if not isinstance(st, Wait):
            self._release_points(ids)
        pos = w.positions[ids]
        if isinstance(st, Wait):
            self.reached[ids, sid] = t
            self.wait_until[ids] = t + st.durations(self.key, ids, sid)
            if self.maps[g].hold[sid]:  # no place before it: they wait where they entered
                spawn = self.spawns[g]
                w.set_goals(ids, pos, goal_region=spawn, arrive_anywhere=isinstance(spawn, (Rect, Disc)), leave=False)
        elif isinstance(st, (GoTo, Leave)):
            area = st.area
            anywhere = isinstance(area, (Rect, Disc))
            if isinstance(st, GoTo) and st.arrive == "free_point":
                # each to its own point, along a field of its own: the area's field ends at
                # the area's edge, and a point behind a fountain in it is not straight ahead
                for a, point in zip(ids, self._free_points(ids, area, sid, w)):
                    try:
                        w.set_goals(a[None], point[None], goal_region=Points(point[None]), leave=False)
                    except ValueError:  # no field cell of its own that clear: the area's field
                        w.set_goals(a[None], point[None], goal_region=area, leave=False)
            else:
                w.set_goals(ids, area.nearest(pos), goal_region=area, arrive_anywhere=anywhere,
                            leave=isinstance(st, Leave))
            self.bound[id(st)] = self.bound.get(id(st), 0) + len(ids)
            self.expect[ids] = True
        elif isinstance(st, Queue):
            q = self.queues[self._queue_of[st.key]]
            q.approach(ids)
            w.set_goals(ids, q.tail, goal_region=q.region, leave=False)
            self.expect[ids] = True
        else:  # Choose: pick per agent, then begin the option picked
            self.reached[ids, sid] = t
            self.until[ids, sid] = t
            picks = self._choose(ids, g, st, sid, w)
            self._count_choice((g, sid), st, picks)
            self._enter_at(ids, np.asarray(self.maps[g].options[sid])[picks], w)
            if st.rechoose is not None:
                self._rechoosing = True
                self.chooser[ids] = sid
                self.recheck_at[ids] = t + st.rechoose

    def _arrive(self, ids: np.ndarray, w: Walkers) -> None:
        """Agents that reached the place of their stage."""
        t = self.time
        self.expect[ids] = False
        code = self.group_of[ids] * (self.since.shape[1] + 1) + self.stage[ids]
        for c in np.unique(code):
            sub = ids[code == c]
            g, sid = int(self.group_of[sub[0]]), int(self.stage[sub[0]])
            st = self.flat[g][sid][1]
            if isinstance(st, Queue):  # at the end of the line: join it
                q = self.queues[self._queue_of[st.key]]
                joined, places = q.join(sub, w.positions[sub], t)
                self.reached[joined, sid] = t
                w.set_goals(joined, places, goal_region=q.region, leave=False)
                if len(q.approaching):
                    w.set_goals(q.approaching, q.tail, goal_region=q.region, leave=False)
                continue
            self.reached[sub, sid] = t
            self.bound[id(st)] -= len(sub)
            if isinstance(st, Leave):
                self.until[sub, sid] = t
                self.done[sub] = self.left[sub] = True
                self.finished_at[sub] = t
                self.exits.setdefault(st.name, []).extend([t] * len(sub))
                self.exit_agents.setdefault(st.name, []).extend(int(a) for a in sub)
                self._release_points(sub)
            else:
                self._next(sub, w)

    def _next(self, ids: np.ndarray, w: Walkers) -> None:
        """Agents that finished their stage go on to the stage after it (the next of its
        route or branch; after a branch's last, the one after its choose)."""
        self.until[ids, self.stage[ids]] = self.time
        after = np.array([self.maps[g].after[sid] for g, sid in zip(self.group_of[ids], self.stage[ids])],
                         dtype=np.int64)
        self._enter_at(ids, after, w)

    @staticmethod
    def _close_up(q: ServiceQueue, w: Walkers) -> None:
        """Send a queue's line, which changed, to its places and those on the way to it
        to its tail."""
        if q.members:
            w.set_goals(np.array(q.members), q.places(), goal_region=q.region, leave=False)
        if len(q.approaching):
            w.set_goals(q.approaching, q.tail, goal_region=q.region, leave=False)

    def _serve(self, q: ServiceQueue, w: Walkers) -> None:
        freed = q.release(self.time)
        if freed is not None:
            self._close_up(q, w)  # the line moves up a place
            self._next(np.array([freed]), w)
        if q.members and not q.serving:
            members = np.asarray(q.members)
            if q.reorder_overtaken(w.positions[members], self.radius[members], self.time):
                self._close_up(q, w)  # each to the place of its new turn
            q.start(self.time, w.positions[q.members[0]], freed is not None)

    # ---- choices and places -------------------------------------------------------------
    def region_of(self, st):
        """The region agents at stage ``st`` (goto, queue or leave) are sent to."""
        return self.queues[self._queue_of[st.key]].region if isinstance(st, Queue) else st.area

    def _choose(self, ids: np.ndarray, g: int, st: Choose, sid: int, w: Walkers) -> np.ndarray:
        """(K,) the option each of ``ids`` (on route ``g``, at its choose ``sid``) takes."""
        if st.by == "weights":
            return self._shares(g, sid, st)[ids]
        dist = self._distances(ids, st, w)
        if st.by == "nearest":
            return np.argmin(dist, axis=1)
        walk = dist / self.pref_speed[ids, None]
        cap, bound = self._crowding(st)
        picks = np.empty(len(ids), dtype=np.int64)
        for k in np.argsort(walk.min(axis=1), kind="stable"):  # the nearest choose first
            j = int(np.argmin(walk[k] + bound / cap))
            picks[k] = j
            bound[j] += 1
        return picks

    def _shares(self, g: int, sid: int, st: Choose) -> np.ndarray:
        """(N,) the option each agent on route ``g`` takes at its weighted choose ``sid``
        (-1 for others): each option takes its weight's share of the route's agents,
        exact to one agent (systematic sampling: the agents in an order drawn per agent,
        laid along the cumulated shares from a start drawn once), so one agent alone
        takes each option with its weight's probability. Set on first use, whoever
        reaches the choose first."""
        got = self._share_of.get((g, sid))
        if got is None:
            members = np.flatnonzero(self.group_of == g)
            order = members[np.argsort(uniforms(self.key, members, DRAW_CHOICE + sid), kind="stable")]
            start = uniforms(self.key, np.array([g]), DRAW_SHARE + sid)[0]
            edges = np.cumsum(st.weights) * len(members)
            got = np.full(len(self.group_of), -1, dtype=np.int64)
            got[order] = np.minimum(np.searchsorted(edges, np.arange(len(members)) + start, side="right"),
                                    len(st.among) - 1)
            self._share_of[(g, sid)] = got
        return got

    def _count_choice(self, key: tuple, st: Choose, picks: np.ndarray, dropped: np.ndarray | None = None) -> None:
        """Count the options taken at choose ``key`` (group, stage id), and those given up
        (``dropped``) by agents choosing again."""
        m = len(st.among)
        counts = self.chosen.setdefault((int(key[0]), int(key[1])), np.zeros(m, dtype=np.int64))
        counts += np.bincount(picks, minlength=m)
        if dropped is not None:
            counts -= np.bincount(dropped, minlength=m)

    def _distances(self, ids: np.ndarray, st: Choose, w: Walkers) -> np.ndarray:
        """(K, m) metres from each of ``ids`` to the place each option of ``st`` leads to
        first (a branch's first stage), round the walls."""
        pos = w.positions[ids]
        return np.column_stack([w.walking_distance(pos, self.region_of(o)) for o in st.heads])

    def _crowding(self, st: Choose) -> tuple[np.ndarray, np.ndarray]:
        """(m,) each option's capacity (persons/s) and the agents bound there now, those
        of the stage it begins with."""
        cap = np.array([o.capacity for o in st.heads])
        bound = np.array([self.queues[self._queue_of[o.key]].bound if isinstance(o, Queue)
                          else self.bound.get(id(o), 0) for o in st.heads], dtype=float)
        return cap, bound

    def _leave_where_they_stand(self, w: Walkers) -> None:
        """Agents walking to an exit (a leave option of a choose) that stand in the area of
        another exit of the same choose, and not in their own's, leave by that one: one
        the crowd carried through the other door has left the room (RiMEA 11 by nearest:
        37 of 1000 bound for the near exit were pressed through the far door into its
        closed exit area and stayed there, one for 420 s)."""
        walking = self.expect & w.active & (self.stage >= 0)
        if not walking.any():
            return
        for (g, sid), (cid, j0, others) in self._sibling_exits.items():
            ids = np.flatnonzero(walking & (self.group_of == g) & (self.stage == sid))
            if not len(ids) or not others:
                continue
            st = self.flat[g][cid][1]
            pos = w.positions[ids]
            own = ~self.flat[g][sid][1].area.contains(pos)  # in its own exit's area too: it leaves there
            ids, pos = ids[own], pos[own]
            for j, other in others:
                inside = self.flat[g][other][1].area.contains(pos)
                for a in ids[inside].tolist():
                    self._switch(a, g, cid, st, j0, j, w)
                ids, pos = ids[~inside], pos[~inside]

    def _switch(self, a: int, g: int, cid: int, st: Choose, j0: int, j: int, w: Walkers) -> None:
        """Agent ``a`` takes option ``j`` of choose ``cid`` (group ``g``) instead of ``j0``."""
        first = np.asarray(self.maps[g].options[cid])
        one = np.array([a])
        self.until[one, first[j0]] = self.time
        self._drop(one, w)
        self._enter(one, g, int(first[j]), w)
        self._count_choice((g, cid), st, np.array([j]), np.array([j0]))

    def _rechoose(self, ids: np.ndarray, w: Walkers) -> None:
        """Agents ``ids`` due to weigh their choice again (``Choose.rechoose``): those
        still walking to the option they took switch, one at a time (the largest saving
        first, each switch counted before the next is weighed), to another option whose
        cost is lower than their own option's by more than ``rechoose_margin``: the
        least-crowded cost (their own option's without themselves among those bound
        there), or by "nearest" the walking time alone; they weigh again ``rechoose``
        seconds later. The others stop re-weighing."""
        walking = self.expect[ids] & (self.chooser[ids] >= 0) & w.active[ids]
        self.recheck_at[ids[~walking]] = np.inf
        self.chooser[ids[~walking]] = -1
        ids = ids[walking]
        code = self.group_of[ids] * (self.since.shape[1] + 1) + self.chooser[ids]
        for c in np.unique(code):
            sub = ids[code == c]
            g, sid = int(self.group_of[sub[0]]), int(self.chooser[sub[0]])
            st = self.flat[g][sid][1]
            walk = self._distances(sub, st, w) / self.pref_speed[sub, None]
            cap, bound = self._crowding(st)
            if st.by == "nearest":  # the walking time alone: nobody bound anywhere weighs
                cap = np.full(len(cap), np.inf)
            first = np.asarray(self.maps[g].options[sid])
            own = np.argmax(self.stage[sub][:, None] == first[None], axis=1)  # the option each is on
            rows = np.arange(len(sub))
            every = walk + bound / cap
            stay = every[rows, own] - 1.0 / cap[own]
            every[rows, own] = np.inf
            saving = stay - every.min(axis=1)
            maybe = np.flatnonzero(saving > st.rechoose_margin)
            moves = []
            for k in maybe[np.argsort(-saving[maybe], kind="stable")]:  # weighed with the switches before
                j0 = int(own[k])
                cost = walk[k] + bound / cap
                stay_k = cost[j0] - 1.0 / cap[j0]
                cost[j0] = np.inf
                j = int(np.argmin(cost))
                if cost[j] < stay_k - st.rechoose_margin:
                    bound[j0] -= 1
                    bound[j] += 1
                    moves.append((int(sub[k]), j0, j))
            for a, j0, j in moves:
                self._switch(a, g, sid, st, j0, j, w)
            self.chooser[sub] = sid
            self.recheck_at[sub] = self.time + st.rechoose

    def _free_points(self, ids: np.ndarray, area, sid: int, w: Walkers) -> np.ndarray:
        """A point of ``area`` for each agent: of FREE_POINT_TRIES drawn, the nearest it
        that is a body and FREE_POINT_GAP_M clear of the points others hold there and of
        obstacles (the clearest, if none is): on the near side of a fountain in it."""
        pos = w.positions[ids]
        m = FREE_POINT_TRIES
        draws = np.stack([uniforms(self.key, ids, DRAW_FREE_POINT + (sid * m + k) * 2) for k in range(m)], axis=1)
        draws2 = np.stack([uniforms(self.key, ids, DRAW_FREE_POINT + (sid * m + k) * 2 + 1) for k in range(m)], axis=1)
        if isinstance(area, Rect):
            cand = area.lower + np.stack([draws, draws2], axis=-1) * (area.upper - area.lower)
        else:
            r, a = area.radius * np.sqrt(draws), 2 * np.pi * draws2
            cand = area.center + np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)
        room = np.full(cand.shape[:2], np.inf) if self.clearance is None else \
            self.clearance(cand.reshape(-1, 2)).reshape(cand.shape[:2])
        held = self.held.setdefault(id(area), {})
        out = np.empty((len(ids), 2))
        for k, a in enumerate(ids):
            rad = self.radius[a]
            others = np.array(list(held.values())) if held else np.zeros((0, 2))
            apart = np.full(m, np.inf) if not len(others) else \
                np.linalg.norm(cand[k][:, None] - others[None], axis=-1).min(axis=1) - 2 * self.radius.max()
            fits = (room[k] >= rad + FREE_POINT_WALL_GAP_M) & (apart >= FREE_POINT_GAP_M)
            near = np.linalg.norm(cand[k] - pos[k], axis=1)  # the nearest that fits: on the near side
            best = int(np.argmin(np.where(fits, near, np.inf))) if fits.any() else \
                int(np.argmax(np.minimum(room[k] - rad, apart)))
            out[k] = cand[k, best]
            held[int(a)] = out[k]
            self.holder[a] = id(area)
        return out

    def _release_points(self, ids: np.ndarray) -> None:
        for a in ids[self.holder[ids] != -1]:
            self.held[int(self.holder[a])].pop(int(a), None)
            self.holder[a] = -1

    # ---- what researchers measure -------------------------------------------------------
    def stage_table(self, names) -> dict:
        """Per group on a route: its stages by id (path in the route, kind, name)."""
        return {self._route_name(names, g): [{"id": sid, "path": path, "kind": st.kind, "name": st.name}
                                             for sid, (path, st, _) in enumerate(f)]
                for g, f in enumerate(self.flat) if f}

    def _route_name(self, names, g: int) -> str:
        """A group's name, or ``route k`` for a route set while running."""
        return str(names[g]) if g < len(names) else f"route {g}"

    def report(self, names) -> dict:
        """For summary.json: per group and stage, the agents that reached it and the mean
        and longest time spent in it (from beginning it to moving on, s), and for a
        choose the agents that took each option; per queue, the agents served, the waits
        in line, its length each second, and when each was served and after how long a
        wait; per exit, the agents that left by it, the flow (persons/s), the persons who
        left in each second and the evacuation time (the last left, s); per group, its
        own waits in each queue and its own use of each exit."""
        stages = {}
        for g, f in enumerate(self.flat):
            if not f:
                continue
            own = self.group_of == g
            rows = []
            for sid, (path, st, _) in enumerate(f):
                spent = (self.until[own, sid] - self.since[own, sid])
                spent = spent[np.isfinite(spent)]
                row = {"id": sid, "path": path, "kind": st.kind, "name": st.name,
                       "reached": int(np.isfinite(self.reached[own, sid]).sum()),
                       "mean_time_s": float(spent.mean()) if len(spent) else None,
                       "max_time_s": float(spent.max()) if len(spent) else None}
                if isinstance(st, Choose):
                    row["chosen"] = self.chosen.get((g, sid), np.zeros(len(st.among), dtype=np.int64)).tolist()
                rows.append(row)
            stages[self._route_name(names, g)] = rows
        exits = {}
        for name, times in self.exits.items():
            t = np.sort(np.array(times))
            overall = flow(t)
            # the N–t curve's stationary part (10-90 % of those who left), as measured at a bottleneck:
            # a straggler long after the crowd does not thin it as it thins the flow over first to last
            start, end, steady = stationary(t)
            exits[name] = {**exit_row(t), "flow_per_s": None if np.isnan(overall) else overall,
                           "steady_flow_per_s": None if np.isnan(steady) else steady,
                           "steady_span_s": None if np.isnan(steady) else [start, end],
                           "left_per_s": np.bincount(np.floor(t + 1e-9).astype(np.int64)).tolist()}
        return {"stages": stages, "queues": {q.stage.name: q.report() for q in self.queues}, "exits": exits,
                "groups": self._group_report(names),
                "finished": int((self.on_route & self.done & ~self.removed).sum()), "on_route": int(self.on_route.sum()),
                # done and still in the scene: their route ends without a leave stage
                "standing_at_end": int((self.on_route & self.done & ~self.removed & ~self.left).sum()),
                "removed": int((self.on_route & self.removed).sum())}

    def _group_report(self, names) -> dict:
        """Per group that used a queue or an exit: its agents' waits in each queue and
        their use of each exit (agents, first and last out), for the per-group report.
        Groups are those of the run (``names``); agents on routes set while running
        count under ``route k``."""
        out: dict = {}
        group_name = [self._route_name(names, g) for g in range(len(self.routes))]
        for q in self.queues:
            if not q.served:
                continue
            agents, joined, released = (np.array(x) for x in zip(*q.served))
            for g in np.unique(self.group_of[agents]):
                own = self.group_of[agents] == g
                out.setdefault(group_name[g], {"queues": {}, "exits": {}})["queues"][q.stage.name] = \
                    {"served": int(own.sum()), **wait_row(released[own] - joined[own])}
        for name, times in self.exits.items():
            t, agents = np.array(times), np.array(self.exit_agents[name])
            for g in np.unique(self.group_of[agents]):
                own = self.group_of[agents] == g
                out.setdefault(group_name[g], {"queues": {}, "exits": {}})["exits"][name] = exit_row(np.sort(t[own]))
        return out


def exit_row(times: np.ndarray) -> dict:
    """Of the (sorted) times agents left by an exit: how many, the first and the
    evacuation time (the last, s)."""
    return {"left": len(times), "first_s": float(times[0]), "evacuation_time_s": float(times[-1])}
