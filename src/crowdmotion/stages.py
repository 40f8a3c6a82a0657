"""Route stages as typed data shared by the methods: go to an area, wait, queue, choose
among several next stages, leave at an exit.

A route is a list of stages a group's agents follow in order (``Group(...,
attributes={"route": [GoTo(Disc([20, 10], 3)), Wait(5.0), Leave(Rect(...))]})``, or a
scenario's ``[[groups.route]]`` tables, see :mod:`crowdmotion.scenario`). The stages hold
no state: :class:`crowdmotion.journeys.Journeys` walks agents along them.

A ``choose`` option is one stage (go to, queue, leave) or a *branch*: a list of stages
the agents who take it follow in turn, ``Choose([[GoTo(fountain), Wait(20), Leave(east)],
Leave(west)], by="weights", weights=[3, 7])``. An agent that finishes a branch goes on
with the stage after the choose (a branch that ends with a leave ends the route there).

Each stage of a route has a number, its *stage id*, counted depth first: ``route[0]`` is
0, and a ``choose`` is followed by its options, a branch by its stages in order
(``route[1]`` = 1, ``route[1].among[0]`` = 2, ``route[1].among[1][0]`` = 3,
``route[1].among[1][1]`` = 4, ...). Trajectories record the stage id of each agent per
frame (-1 off route).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

import numpy as np

from crowdmotion._rng import uniforms
from crowdmotion.geometry import finite_array, finite_number
from crowdmotion.groups import Disc, Points, Rect, describe_region
from crowdmotion.stage_kinds import KINDS  # noqa: F401 (re-exported: the kinds of the stages below)

SPECIFIC_FLOW = 1.3  # persons per metre of opening per second (bottleneck flow): an area's capacity by default
QUEUE_SPACING_M = 0.65  # metres between two places in a queue
ARRIVE = ("anywhere", "free_point")
CHOOSE_BY = ("nearest", "least_crowded", "weights")
DISTRIBUTIONS = ("uniform", "normal")
RECHOOSE_MARGIN_S = 2.0  # seconds of cost another option must save before an agent re-choosing switches


def _area(area, what: str):
    if not isinstance(area, (Rect, Disc, Points)) or area.dim != 2:
        raise ValueError(f"{what} must be a 2D Rect, Disc or Points region (routes are 2D), got {area!r}")
    return area


STRIP_M = 1.0  # a rect thinner than this is a strip laid across an opening: its length is the opening


def opening_width(area) -> float:
    """Metres of opening an area offers walkers, for its default capacity: a Rect's
    shorter side (the width of the passage it spans), or its longer side when the shorter
    is under STRIP_M (a strip laid across an opening); a Disc's diameter; one body
    (0.6 m) for points; never below 0.6 m."""
    if isinstance(area, Rect):
        short, long = np.sort(area.upper - area.lower)
        width = long if short < STRIP_M else short
    elif isinstance(area, Disc):
        width = 2.0 * area.radius
    else:
        width = 0.6
    return max(float(width), 0.6)


def _capacity(value, area, what: str) -> float:
    """``value`` persons/s, or by default SPECIFIC_FLOW × the area's :func:`opening_width`."""
    if value is None:
        return SPECIFIC_FLOW * opening_width(area)
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{what}.capacity must be > 0 persons per second, got {value!r}")
    return v


def _name(value, default: str) -> str:
    if value is None:
        return default
    if not isinstance(value, str) or not value:
        raise ValueError(f"a stage's name must be a non-empty string, got {value!r}")
    return value


def describe(area) -> str:
    """An area as a scenario file writes it, for names and messages."""
    return describe_region(area)


@dataclass(eq=False)
class GoTo:
    """Walk to ``area``: arrive anywhere in it (``arrive = "anywhere"``, its nearest point
    along the guidance field) or at a free point of it (``"free_point"``: a point no one
    else bound there holds, at least a body apart; Rect or Disc areas).

    capacity : persons/s the area takes in, for ``choose by least_crowded`` (default
    SPECIFIC_FLOW × its :func:`opening_width`)."""

    area: Rect | Disc | Points
    arrive: str = "anywhere"
    name: str | None = None
    capacity: float | None = None
    kind = "goto"

    def __post_init__(self):
        self.area = _area(self.area, "goto.area")
        if self.arrive not in ARRIVE:
            raise ValueError(f"goto.arrive must be one of {', '.join(ARRIVE)}, got {self.arrive!r}")
        if self.arrive == "free_point" and isinstance(self.area, Points):
            raise ValueError("goto.arrive = 'free_point' needs a rect or disc area, not points")
        self.capacity = _capacity(self.capacity, self.area, "goto")
        self.name = _name(self.name, f"goto {describe(self.area)}")


@dataclass(eq=False)
class Leave:
    """Walk to ``area`` and leave the scene on arriving anywhere in it (an exit).

    capacity : persons/s the exit passes, for ``choose by least_crowded`` (default
    SPECIFIC_FLOW × its :func:`opening_width`)."""

    area: Rect | Disc | Points
    name: str | None = None
    capacity: float | None = None
    kind = "leave"

    def __post_init__(self):
        self.area = _area(self.area, "leave.area")
        self.capacity = _capacity(self.capacity, self.area, "leave")
        self.name = _name(self.name, f"exit {describe(self.area)}")


@dataclass(eq=False)
class Wait:
    """Stand where the last stage left the agent for ``time`` seconds: a number, or a
    distribution drawn per agent from the run's seed: ``{"uniform": [low, high]}`` or
    ``{"normal": [mean, sd]}`` (clipped at 0)."""

    time: float | dict
    name: str | None = None
    kind = "wait"

    def __post_init__(self):
        t = self.time
        if isinstance(t, dict):
            if len(t) != 1 or next(iter(t)) not in DISTRIBUTIONS:
                raise ValueError(f"wait.time must be seconds, {{uniform = [low, high]}} or {{normal = [mean, sd]}}, "
                                 f"got {t!r}")
            (law, args), = t.items()
            try:
                a, b = (float(x) for x in args)
            except (TypeError, ValueError):
                raise ValueError(f"wait.time.{law} must be two numbers, got {args!r}") from None
            if not (np.isfinite(a) and np.isfinite(b)) or a < 0 or b < 0:
                raise ValueError(f"wait.time.{law} must be two finite numbers >= 0, got {args!r}")
            if law == "uniform" and b < a:
                raise ValueError(f"wait.time.uniform: low {a:g} exceeds high {b:g}")
            self.time = {law: (a, b)}
            default = f"wait {law}({a:g}, {b:g}) s"
        else:
            if not finite_number(t) or t < 0:
                raise ValueError(f"wait.time must be a number of seconds >= 0, got {t!r}")
            self.time = float(t)
            default = f"wait {self.time:g} s"
        self.name = _name(self.name, default)

    def durations(self, key, agents: np.ndarray, draw: int) -> np.ndarray:
        """(K,) seconds each of ``agents`` waits: the same for the same (key, agent, draw)."""
        n = len(agents)
        if not isinstance(self.time, dict):
            return np.full(n, self.time)
        (law, (a, b)), = self.time.items()
        u1 = uniforms(key, agents, 2 * draw)
        if law == "uniform":
            return a + (b - a) * u1
        u2 = uniforms(key, agents, 2 * draw + 1)
        normal = np.sqrt(-2.0 * np.log1p(-u1)) * np.cos(2.0 * np.pi * u2)  # Box-Muller, u1 in [0, 1)
        return np.maximum(a + b * normal, 0.0)


@dataclass(eq=False)
class Queue:
    """Queue at ``head`` and be served there one at a time, first come first served, at
    ``rate`` persons per second. The line forms behind the head, one place every
    ``spacing`` metres: along ``direction`` (a vector from the head), or along the
    polyline ``line`` (its first point the head, ``head`` then None or that point;
    beyond its end it goes on straight).
    Service starts once the first in line stands within one spacing of the head.

    capacity : persons/s, for ``choose by least_crowded`` (default ``rate``)."""

    head: np.ndarray | None
    rate: float
    direction: np.ndarray | None = None
    line: np.ndarray | None = None
    spacing: float = QUEUE_SPACING_M
    name: str | None = None
    capacity: float | None = None
    kind = "queue"

    def __post_init__(self):
        if self.head is None and self.line is not None:
            self.head = np.asarray(self.line, dtype=float)[0]
        self.head = finite_array(self.head, "queue.head").ravel()
        if self.head.shape != (2,):
            raise ValueError(f"queue.head must be a 2D point, got {self.head.tolist()}")
        r = self.rate
        if not finite_number(r) or r <= 0:
            raise ValueError(f"queue.rate must be > 0 persons per second, got {r!r}")
        self.rate = float(r)
        s = self.spacing
        if not finite_number(s) or s <= 0:
            raise ValueError(f"queue.spacing must be > 0 metres, got {s!r}")
        self.spacing = float(s)
        if (self.direction is None) == (self.line is None):
            raise ValueError("queue: give either direction (from the head, the way the line grows) or line "
                             "(a polyline from the head)")
        if self.direction is not None:
            d = finite_array(self.direction, "queue.direction").ravel()
            if d.shape != (2,) or np.linalg.norm(d) == 0:
                raise ValueError(f"queue.direction must be a non-zero 2D vector, got {d.tolist()}")
            self.direction = d / np.linalg.norm(d)
            self._line = np.stack([self.head, self.head + self.direction])
        else:
            line = finite_array(self.line, "queue.line")
            if line.ndim != 2 or line.shape[1] != 2 or len(line) < 2:
                raise ValueError(f"queue.line must be at least two [x, y] points, got shape {line.shape}")
            if np.any(np.linalg.norm(np.diff(line, axis=0), axis=1) == 0):
                raise ValueError("queue.line must not repeat a point")
            self.line = line
            self.head = line[0].copy()
            self._line = line
        self.capacity = self.rate if self.capacity is None else _capacity(self.capacity, None, "queue")
        self.name = _name(self.name, f"queue at {describe(Points(self.head[None]))}")

    def slots(self, count: int) -> np.ndarray:
        """(count, 2) the places in line: 0 at the head, one every ``spacing`` metres."""
        seg = np.diff(self._line, axis=0)
        length = np.linalg.norm(seg, axis=1)
        along = np.concatenate([[0.0], np.cumsum(length)])
        s = np.arange(count) * self.spacing
        k = np.clip(np.searchsorted(along, s, side="right") - 1, 0, len(seg) - 1)
        return self._line[k] + seg[k] * ((s - along[k]) / length[k])[:, None]

    @property
    def key(self) -> tuple:
        """Equal for queues at the same place served the same way (shared by groups)."""
        return ("queue", tuple(self._line.ravel().round(9)), self.rate, self.spacing)


PLACES = (GoTo, Queue, Leave)  # stages with a place to walk to: a choose's one-stage options
Option = Union[GoTo, Queue, Leave, list]  # a list: a branch of stages


@dataclass(eq=False)
class Choose:
    """Go on with one of the options ``among``, chosen per agent: ``"nearest"`` (the least
    walking distance along the guidance field), ``"least_crowded"`` (the least walking
    time plus the agents already bound there over the stage's capacity, persons/s) or
    ``"weights"`` (each option takes its weight's share of the route's agents, exact to
    one agent; who takes which is drawn from the run's seed).

    An option is one stage (go to, queue or leave) or a *branch*: a list of stages
    (any kind) the agents who take it follow in turn, then going on with the stage after
    the choose; a branch that ends with a leave ends the route there, so a choose with
    such a branch must be its route's (or its branch's) last stage. ``nearest`` and
    ``least_crowded`` weigh a branch by the stage it begins with (a go to, queue or
    leave); with ``weights`` a branch may begin with any stage, or be empty (those who
    take it go straight on).

    The choice is made once, on entering the stage, unless ``rechoose`` is set (seconds;
    by = "nearest" or "least_crowded"): then an agent still walking to the option it took
    (not yet arrived at its first stage, or not yet in its queue's line) weighs the
    options again every ``rechoose`` seconds and switches to another whose cost is lower
    by more than ``rechoose_margin`` seconds (default RECHOOSE_MARGIN_S; only with
    ``rechoose``). By "least_crowded" the cost is the walking time plus those bound there
    over the capacity, its own option counted without itself: as a queue at one exit
    builds, those still on their way take another. By "nearest" it is the walking time alone: an agent
    takes the option nearer where it walks now (people leaving a corridor by the side
    exit on the side they walk). The margin keeps an agent from switching back and forth
    between options of about the same cost."""

    among: list
    by: str = "nearest"
    weights: list | None = None
    name: str | None = None
    rechoose: float | None = None
    rechoose_margin: float | None = None
    kind = "choose"

    def __post_init__(self):
        self.among = [list(o) if isinstance(o, (list, tuple)) else o for o in self.among]
        if len(self.among) < 2:
            raise ValueError(f"choose.among must list at least two stages or branches, got {len(self.among)}")
        for j, o in enumerate(self.among):
            if isinstance(o, list):
                _check_stages(o, f"choose.among.{j}", empty=True)
            elif not isinstance(o, PLACES):
                raise ValueError(f"choose.among.{j} must be a goto, queue or leave stage, or a list of stages "
                                 f"(a branch), got {o!r}")
        if self.by not in CHOOSE_BY:
            raise ValueError(f"choose.by must be one of {', '.join(CHOOSE_BY)}, got {self.by!r}")
        if (self.by == "weights") != (self.weights is not None):
            raise ValueError("choose: weights go with by = 'weights' (and it needs them)")
        if self.by != "weights":
            for j, head in enumerate(self.heads):
                if not isinstance(head, PLACES):
                    raise ValueError(f"choose.among.{j}: by = {self.by!r} weighs each option by the place it leads "
                                     f"to first, but this branch " + ("is empty" if head is None else
                                                                      f"begins with a {head.kind}")
                                     + ": begin it with a goto, queue or leave stage, or choose by weights")
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=float)
            if w.shape != (len(self.among),) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
                raise ValueError(f"choose.weights must be {len(self.among)} numbers >= 0, not all 0, "
                                 f"got {self.weights!r}")
            self.weights = (w / w.sum()).tolist()
        if self.rechoose is not None:
            if self.by == "weights":
                raise ValueError("choose.rechoose goes with by = 'nearest' or 'least_crowded' (a choice that "
                                 "changes as the agent walks or others choose), not by = 'weights'")
            self.rechoose = _seconds(self.rechoose, "choose.rechoose", positive=True)
        if self.rechoose_margin is not None and self.rechoose is None:
            raise ValueError("choose.rechoose_margin goes with rechoose (seconds between two looks at the choice), "
                             f"got a margin of {self.rechoose_margin!r} and no rechoose")
        self.rechoose_margin = RECHOOSE_MARGIN_S if self.rechoose_margin is None else \
            _seconds(self.rechoose_margin, "choose.rechoose_margin", positive=False)
        self.name = _name(self.name, f"choose {self.by}")

    @property
    def branches(self) -> list[list]:
        """Each option as a list of stages (a one-stage option as a branch of one)."""
        return [o if isinstance(o, list) else [o] for o in self.among]

    @property
    def heads(self) -> list:
        """The stage each option begins with (its place weighs it for ``nearest`` and
        ``least_crowded``); None for an empty branch."""
        return [b[0] if b else None for b in self.branches]


def _seconds(value, what: str, positive: bool) -> float:
    """``value`` as a finite number of seconds (> 0, or >= 0), else ValueError naming ``what``."""
    if not finite_number(value) or value < 0 or (positive and value == 0):
        raise ValueError(f"{what} must be a number of seconds {'> 0' if positive else '>= 0'}, got {value!r}")
    return float(value)


Stage = Union[GoTo, Wait, Queue, Choose, Leave]


def leaves(stage) -> bool:
    """Whether agents may leave the scene at ``stage``: a leave, or a choose with an
    option that ends with one."""
    if isinstance(stage, Leave):
        return True
    return isinstance(stage, Choose) and any(b and leaves(b[-1]) for b in stage.branches)


def _places(stages) -> bool:
    """Whether every way through ``stages`` passes a stage with a place (goto, queue, leave)."""
    return any(isinstance(s, PLACES) or (isinstance(s, Choose) and all(_places(b) for b in s.branches))
               for s in stages)


def _check_stages(stages, where: str, empty: bool = False) -> list:
    """``stages`` (a route, or a choose's branch at ``where``) as a list, refused
    (ValueError naming the stage) unless each is a stage and one where agents leave the
    scene comes last; an empty list only where ``empty``."""
    if not isinstance(stages, (list, tuple)) or (not stages and not empty):
        raise ValueError(f"{where} must be a non-empty list of stages, got {stages!r}")
    for i, s in enumerate(stages):
        if not isinstance(s, (GoTo, Wait, Queue, Choose, Leave)):
            raise ValueError(f"{where}.{i} must be a GoTo, Wait, Queue, Choose or Leave stage, got {s!r}")
        if leaves(s) and i != len(stages) - 1:
            if isinstance(s, Leave):
                raise ValueError(f"{where}.{i} ({s.kind}): an agent leaves the scene there, so it must be the last "
                                 f"stage")
            j = next(j for j, b in enumerate(s.branches) if b and leaves(b[-1]))
            raise ValueError(f"{where}.{i} ({s.kind}): agents taking among.{j} leave the scene, so the choose must "
                             f"be the last stage: move the stages after it to the end of the options that go on")
    return list(stages)


def check_route(route, where: str = "route") -> list:
    """``route`` as a list of stages, refused (ValueError naming the stage) unless it is a
    non-empty list of GoTo, Wait, Queue, Choose and Leave, with a stage where agents
    leave the scene (a leave, or a choose with an option ending in one) only last."""
    return _check_stages(route, where)


def field_path(path: str) -> str:
    """A stage's path as a scenario field: ``route[2].among[1][0]`` -> ``route.2.among.1.0``."""
    return path.replace("[", ".").replace("]", "")


def stage_label(path: str, st) -> str:
    """A stage as an error names it: its field and what it is, ``route.2 (queue 'gate')``."""
    return f"{field_path(path)} ({st.kind} {st.name!r})"


@dataclass(frozen=True)
class RouteMap:
    """A route's stages by stage id, and how an agent moves between them.

    stages : per stage id, (path, stage, index of its top-level stage), depth first
    after : per stage id, the stage id an agent goes on to when done with it
        (``len(stages)``: the route's end)
    options : per choose's stage id, the stage id each of its options begins at (an
        empty branch: the choose's ``after``)
    hold : per stage id, True where some way from the route's start reaches it without
        passing a place (a wait there stands where the agent entered)
    """

    stages: list
    after: list
    options: dict
    hold: list


def route_map(route) -> RouteMap:
    """The :class:`RouteMap` of ``route``: stage ids counted depth first (``route[i]``,
    then a choose's options ``route[i].among[j]`` (one stage) or ``route[i].among[j][k]``
    (a branch's stages), each followed by what it holds)."""
    flat: list = []

    def number(stages, prefix: str, top: int | None, single: bool) -> list:
        ids = []
        for k, s in enumerate(stages):
            path = prefix if single else f"{prefix}[{k}]"
            t = k if top is None else top
            sid = len(flat)
            flat.append((path, s, t))
            kids = [number(b, f"{path}.among[{j}]", t, not isinstance(o, list))
                    for j, (o, b) in enumerate(zip(s.among, s.branches))] if isinstance(s, Choose) else []
            ids.append((sid, kids))
        return ids

    tree = number(list(route), "route", None, False)
    after = [len(flat)] * len(flat)
    options: dict = {}
    hold = [False] * len(flat)

    def link(ids: list, then: int, placed: bool) -> None:
        for k, (sid, kids) in enumerate(ids):
            after[sid] = ids[k + 1][0] if k + 1 < len(ids) else then
            st = flat[sid][1]
            hold[sid] = not placed
            if isinstance(st, Choose):
                options[sid] = [kid[0][0] if kid else after[sid] for kid in kids]
                for kid in kids:
                    link(kid, after[sid], placed)
            placed = placed or _places([st])

    link(tree, len(flat), False)
    return RouteMap(flat, after, options, hold)


def flat_stages(route) -> list[tuple[str, object, int]]:
    """Every stage of ``route`` with its stage id (the list index): (path, stage, index
    of its top-level stage), depth first: ``route[i]``, then a choose's options
    ``route[i].among[j]``, a branch's stages ``route[i].among[j][k]`` (see :func:`route_map`)."""
    return route_map(route).stages


def refuse_unfollowed(route, where: str, follows: tuple[str, ...], who: str) -> None:
    """Refuse (ValueError naming the stage) a route with a stage whose kind is not in
    ``follows``, the kinds a method's ``who`` ("a formation", "a PSO swarm") follows."""
    for path, st, _ in flat_stages(route):
        if st.kind not in follows:
            raise ValueError(f"{where} {stage_label(path, st)}: {who} does not {st.kind}; "
                             f"it follows {', '.join(follows)} stages")


def route_areas(route) -> list:
    """The regions a route's agents walk to (areas, and each queue's line of places for
    ``count`` agents is added by the caller), in order, without repeats."""
    out = []
    for _, s, _ in flat_stages(route):
        area = getattr(s, "area", None)
        if area is not None and all(a is not area for a in out):
            out.append(area)
    return out
