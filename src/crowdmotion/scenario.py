"""Scenario TOML files: schema (pydantic), loading with field-named errors, and running.

A scenario is one TOML file: ``[scene]`` (bounds, obstacles), ``[[groups]]``,
``method`` with its own parameter block (``[mdp]``, ``[rvo]``, ``[pso]``, ``[formation]``), ``seed`` and ``[output]``. Nothing
in the file is ever executed. Each method adds its block here without changing the rest.
"""

from __future__ import annotations

import difflib
import re
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationError, field_validator, model_validator

from crowdmotion import groups as G
from crowdmotion._validation import Coordinate, NonNegative, Positive, error_lines, field_names, shown
from crowdmotion.formation.params import STAGES as FORMATION_STAGES
from crowdmotion.formation.params import FormationAttributes, FormationParams, TemplateSpec
from crowdmotion.mdp.params import STAGES as MDP_STAGES
from crowdmotion.mdp.params import MDPParams
from crowdmotion.pso.params import STAGES as PSO_STAGES
from crowdmotion.pso.params import PSOParams
from crowdmotion.rvo.params import STAGES as RVO_STAGES
from crowdmotion.rvo.params import RVOAttributes, RVOParams
from crowdmotion.stage_kinds import KINDS as STAGE_KINDS
from crowdmotion import scene as S


class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message names each bad field and value."""


METHODS = ("mdp", "rvo", "pso", "formation")
# what a group's ``attributes`` table may hold, per method (None: nothing)
ATTRIBUTES: dict[str, type[BaseModel] | None] = {"mdp": None, "rvo": RVOAttributes, "pso": None,
                                                 "formation": FormationAttributes}
# [[groups]] fields only one method reads
GROUP_FIELD_METHOD = {"personality": ("rvo",), "formation": ("formation",),
                      "enter": ("rvo", "mdp", "formation", "pso")}
# methods whose groups enter as one unit (enter = { start = s } only), and what they call a group
UNIT_ENTRY = {"formation": "a formation", "pso": "a PSO swarm"}
# the route stages each method follows, as each method's params module says
ROUTE_SUPPORT = {"rvo": RVO_STAGES, "mdp": MDP_STAGES, "pso": PSO_STAGES, "formation": FORMATION_STAGES}


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


Coord = Annotated[list[Coordinate], Field(min_length=2, max_length=3)]
PosFloat = Positive
Speed = Annotated[float, Field(gt=0, le=1000.0, allow_inf_nan=False)]  # m/s
Times = Annotated[list[Coordinate], Field(min_length=1)]


def _keyframes(times: list[float], positions: list) -> None:
    """Keyframes as a path needs them: one position per time, times increasing."""
    if len(times) != len(positions):
        raise ValueError(f"times and positions must give one position per time, got {len(times)} time(s) and "
                         f"{len(positions)} position(s)")
    back = next((i for i in range(1, len(times)) if times[i] <= times[i - 1]), None)
    if back is not None:
        raise ValueError(f"times must increase, got {times[back - 1]:g} then {times[back]:g}")


class PathSpec(_Model):
    """A keyframed path: the obstacle's centre moves through ``positions`` at ``times``,
    linearly between keyframes (held before the first and after the last).

    times : list       keyframe times, seconds, increasing
    positions : list   one [x, y] or [x, y, z] centre per keyframe, metres
    """

    times: Times
    positions: list[Coord]

    @model_validator(mode="after")
    def _keyframes(self):
        _keyframes(self.times, self.positions)
        return self


class CircleSpec(_Model):
    """A disc obstacle (2D scenes).

    shape : str        "circle"
    center : list      [x, y] centre, metres
    radius : float     metres
    path : table       optional keyframed motion (PathSpec); without one it stands still
    """

    shape: Literal["circle"]
    center: Coord
    radius: PosFloat
    path: PathSpec | None = None


class SphereSpec(_Model):
    """A ball obstacle (3D scenes).

    shape : str        "sphere"
    center : list      [x, y, z] centre, metres
    radius : float     metres
    path : table       optional keyframed motion (PathSpec)
    """

    shape: Literal["sphere"]
    center: Coord
    radius: PosFloat
    path: PathSpec | None = None


class BoxSpec(_Model):
    """An axis-aligned box obstacle (a rectangle in 2D).

    shape : str        "box"
    lower : list       lowest corner [x, y(, z)], metres
    upper : list       highest corner, metres
    path : table       optional keyframed motion (PathSpec)
    """

    shape: Literal["box"]
    lower: Coord
    upper: Coord
    path: PathSpec | None = None


class PolygonSpec(_Model):
    """A simple polygon obstacle (2D scenes), through shapely.

    shape : str        "polygon"
    vertices : list    at least three [x, y] corners, in order, metres
    path : table       optional keyframed motion (PathSpec)
    """

    shape: Literal["polygon"]
    vertices: list[Annotated[list[Coordinate], Field(min_length=2, max_length=2)]] = Field(min_length=3)
    path: PathSpec | None = None


ObstacleSpec = Annotated[Union[CircleSpec, SphereSpec, BoxSpec, PolygonSpec], Field(discriminator="shape")]


class SceneSpec(_Model):
    """The world: axis-aligned bounds (their dimension makes the scene 2D or 3D) and obstacles.

    bounds : list      [lower corner, upper corner], each [x, y] or [x, y, z], metres
    obstacles : list   obstacle tables, each with a ``shape`` (see the tables below)
    """

    bounds: Annotated[list[Coord], Field(min_length=2, max_length=2)]
    obstacles: list[ObstacleSpec] = []


class PointRegion(_Model):
    """One point: a spawn (one agent, or a formation placed there) or a goal shared by the group.

    shape : str        "point"
    position : list    [x, y(, z)], metres
    """

    shape: Literal["point"]
    position: Coord


class PointsRegion(_Model):
    """Listed points: one start per agent (spawn), or goal points (one, or one per agent:
    rvo sends agent k to point k; mdp takes the points as the group's goal cells, any
    agent to any free one; pso gathers on their centre; see each method's docs).

    shape : str        "points"
    points : list      [x, y(, z)] points, metres
    """

    shape: Literal["points"]
    points: list[Coord] = Field(min_length=1)


class RectRegion(_Model):
    """An axis-aligned rectangle (a box in 3D) to spawn in or to reach.

    shape : str        "rect"
    lower : list       lowest corner, metres
    upper : list       highest corner, metres
    """

    shape: Literal["rect"]
    lower: Coord
    upper: Coord


class DiscRegion(_Model):
    """A disc (a ball in 3D) to spawn in or to reach.

    shape : str        "disc"
    center : list      centre, metres
    radius : float     metres
    """

    shape: Literal["disc"]
    center: Coord
    radius: PosFloat


class MovingRegion(_Model):
    """Goal only: a target moving through keyframes (linear in between).

    shape : str        "moving"
    times : list       keyframe times, seconds, increasing
    positions : list   one point per keyframe, metres
    """

    shape: Literal["moving"]
    times: Times
    positions: list[Coord]

    @model_validator(mode="after")
    def _keyframes(self):
        _keyframes(self.times, self.positions)
        return self


class RingRegion(_Model):
    """Spawn only: the group's agents evenly spaced on a circle (the antipodal-circle scene).

    shape : str        "ring"
    center : list      [x, y] centre, metres
    radius : float     metres
    phase_deg : float  angle of the first agent, degrees
    """

    shape: Literal["ring"]
    center: Annotated[list[Coordinate], Field(min_length=2, max_length=2)]
    radius: PosFloat
    phase_deg: Annotated[float, Field(ge=-360_000, le=360_000, allow_inf_nan=False)] = 0.0


class LatticeRegion(_Model):
    """Spawn only (2D): the group's agents in rows on a triangular lattice filling the
    rectangle evenly, at the widest spacing their count allows (a dense block start, up
    to about 3.8 persons/m² at radius 0.25 m; a rect's random draws stop near 2).

    shape : str        "lattice"
    lower : list       [x, y] lowest corner, metres
    upper : list       [x, y] highest corner, metres
    """

    shape: Literal["lattice"]
    lower: Annotated[list[Coordinate], Field(min_length=2, max_length=2)]
    upper: Annotated[list[Coordinate], Field(min_length=2, max_length=2)]

    @model_validator(mode="after")
    def _corners(self):
        if any(h < lo for lo, h in zip(self.lower, self.upper)):
            raise ValueError(f"upper {self.upper} must not be below lower {self.lower}")
        return self


class AntipodalRegion(_Model):
    """Goal only: each agent heads for the mirror image of its start through ``center``.

    shape : str        "antipodal"
    center : list      the mirror point, metres
    """

    shape: Literal["antipodal"]
    center: Coord


RegionSpec = Annotated[Union[PointRegion, PointsRegion, RectRegion, DiscRegion, MovingRegion, RingRegion,
                             LatticeRegion, AntipodalRegion], Field(discriminator="shape")]


class EnterSpec(_Model):
    """When and where the group's agents enter, instead of all at t = 0 at the spawn
    (crowdmotion.journeys). rvo and mdp read every key; a formation and a PSO swarm enter
    as one unit and read ``start`` only (validate names any other key).

    rate : float        persons per second, the first at ``start``
    start : float       seconds (default 0)
    end : float         seconds, after start: with rate, the window the whole group must
                        enter in (count ≤ floor(rate·(end − start)) + 1); without rate,
                        the group is spread evenly over [start, end]
    times : list        seconds, one per agent (instead of rate, start and end)
    entrances : list    areas (point, points, rect or disc tables) the agents enter at,
                        instead of the spawn; each agent is given one, from the seed
    weights : list      with entrances: the share of the group each takes (default equal)
    """

    rate: PosFloat | None = None
    start: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0
    end: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None
    times: list[Annotated[float, Field(ge=0, allow_inf_nan=False)]] | None = None
    entrances: Annotated[list["AreaSpec"], Field(min_length=1)] | None = None
    weights: list[NonNegative] | None = None


Point2 = Annotated[list[Coordinate], Field(min_length=2, max_length=2)]
AreaSpec = Annotated[Union[PointRegion, PointsRegion, RectRegion, DiscRegion], Field(discriminator="shape")]
StageName = Annotated[str, Field(min_length=1)]
EnterSpec.model_rebuild()


class WaitTimeSpec(_Model):
    """A waiting time drawn per agent from the scenario's seed (a wait stage's ``time``).

    uniform : list      [low, high] seconds, uniform in between
    normal : list       [mean, sd] seconds, normal, clipped at 0
    """

    uniform: Annotated[list[NonNegative], Field(min_length=2, max_length=2)] | None = None
    normal: Annotated[list[NonNegative], Field(min_length=2, max_length=2)] | None = None

    @model_validator(mode="after")
    def _one(self):
        if (self.uniform is None) == (self.normal is None):
            raise ValueError("give one of uniform = [low, high] or normal = [mean, sd]")
        if self.uniform is not None and self.uniform[0] > self.uniform[1]:
            raise ValueError(f"uniform: low {self.uniform[0]:g} exceeds high {self.uniform[1]:g}")
        return self


class GotoStageSpec(_Model):
    """Route stage: walk to an area (crowdmotion.stages.GoTo).

    kind : str          "goto"
    area : table        a point, points, rect or disc region
    arrive : str        "anywhere" (its nearest point, round walls) or "free_point" (a
                        point of a rect or disc no one else bound there holds)
    name : str          the stage's name in summary.json (default: kind and area)
    capacity : float    persons/s it takes in, for choose by "least_crowded" (default 1.3
                        persons/m/s times the area's width: a rect's shorter side, its
                        longer one if the shorter is under 1 m; a disc's diameter)
    """

    kind: Literal["goto"]
    area: AreaSpec
    arrive: Literal["anywhere", "free_point"] = "anywhere"
    name: StageName | None = None
    capacity: PosFloat | None = None


class WaitStageSpec(_Model):
    """Route stage: stand where the last stage left the agent (crowdmotion.stages.Wait).

    kind : str          "wait"
    time : float        seconds, or a table drawn per agent: {uniform = [low, high]} or
                        {normal = [mean, sd]} (clipped at 0)
    name : str          the stage's name in summary.json
    """

    kind: Literal["wait"]
    time: NonNegative | WaitTimeSpec
    name: StageName | None = None


class QueueStageSpec(_Model):
    """Route stage: queue and be served one at a time, first come first served
    (crowdmotion.stages.Queue).

    kind : str          "queue"
    head : list         [x, y] where the first in line is served (with direction)
    direction : list    [dx, dy] the way the line grows from the head
    line : list         instead of head and direction: a polyline [[x, y], ...] from the
                        head along which the line forms (straight on past its end)
    rate : float        persons served per second
    spacing : float     metres between two places in line
    name : str          the queue's name in summary.json
    capacity : float    persons/s, for choose by "least_crowded" (default: rate)
    """

    kind: Literal["queue"]
    head: Point2 | None = None
    direction: Point2 | None = None
    line: Annotated[list[Point2], Field(min_length=2)] | None = None
    rate: PosFloat
    spacing: PosFloat = 0.65
    name: StageName | None = None
    capacity: PosFloat | None = None

    @model_validator(mode="after")
    def _where(self):
        if self.line is None and (self.head is None or self.direction is None):
            raise ValueError("give head and direction, or line (its first point the head)")
        if self.line is not None and (self.head is not None or self.direction is not None):
            raise ValueError("line replaces head and direction: give one or the other")
        if self.direction is not None and self.direction == [0.0, 0.0]:
            raise ValueError("direction must not be [0, 0]")
        return self


class LeaveStageSpec(_Model):
    """Route stage: walk to an exit and leave the scene there (crowdmotion.stages.Leave).

    kind : str          "leave"
    area : table        a point, points, rect or disc region: arriving anywhere in it
    name : str          the exit's name in summary.json (flow, evacuation time)
    capacity : float    persons/s it passes, for choose by "least_crowded" (default 1.3
                        persons/m/s times the area's width: a rect's shorter side, its
                        longer one if the shorter is under 1 m; a disc's diameter)
    """

    kind: Literal["leave"]
    area: AreaSpec
    name: StageName | None = None
    capacity: PosFloat | None = None


OptionSpec = Annotated[Union[GotoStageSpec, QueueStageSpec, LeaveStageSpec], Field(discriminator="kind")]


def _option_tag(value: Any) -> str:
    """A choose option as written: a list of stages is a branch, anything else one stage."""
    return "branch" if isinstance(value, list) else "stage"


# one stage (goto, queue, leave), or a branch: a list of stages followed in turn
ChoiceSpec = Annotated[Union[Annotated[OptionSpec, Tag("stage")], Annotated[list["StageSpec"], Tag("branch")]],
                       Discriminator(_option_tag)]


class ChooseStageSpec(_Model):
    """Route stage: go on with one of several stages, chosen per agent
    (crowdmotion.stages.Choose).

    kind : str          "choose"
    by : str            "nearest" (walking distance round walls), "least_crowded" (walking
                        time + agents already bound there / the stage's capacity) or
                        "weights" (each option its weight's share of the group, exact to
                        one agent; who takes which drawn from the seed)
    among : list        the options to choose from: each a goto, queue or leave table, or
                        a branch: a list of stage tables followed in turn, then the stage
                        after the choose (a branch ending with a leave ends the route).
                        nearest and least_crowded weigh a branch by its first stage (a
                        goto, queue or leave); with weights a branch may begin with any
                        stage, or be empty (straight on)
    weights : list      with by = "weights": one weight per stage of among
    name : str          the stage's name in summary.json
    rechoose : float    with by = "nearest" or "least_crowded": seconds between two looks
                        at the choice by agents still walking to the option they took;
                        each switches to an option cheaper by more than rechoose_margin
                        (default: chosen once, on entering the stage)
    rechoose_margin : float  seconds of cost (walking time, + bound / capacity by
                        least_crowded) another option must save before an agent switches
                        (default 2)
    """

    kind: Literal["choose"]
    by: Literal["nearest", "least_crowded", "weights"] = "nearest"
    among: Annotated[list[ChoiceSpec], Field(min_length=2)]
    weights: list[NonNegative] | None = None
    name: StageName | None = None
    rechoose: Positive | None = None
    rechoose_margin: NonNegative | None = None

    @model_validator(mode="before")
    @classmethod
    def _bare_options(cls, data):
        """A wait or choose written as an option by itself: say how to write it."""
        if isinstance(data, dict) and isinstance(data.get("among"), list):
            for j, option in enumerate(data["among"]):
                kind = option.get("kind") if isinstance(option, dict) else None
                if kind in ("wait", "choose"):
                    raise ValueError(f"among.{j}: a {kind} stage is no option by itself (an option is a goto, "
                                     f"queue or leave, or a branch: a list of stages); put it in a branch after "
                                     f"the place it happens at: among = [[{{ kind = \"goto\", ... }}, "
                                     f"{{ kind = \"{kind}\", ... }}], ...]")
        return data

    @model_validator(mode="after")
    def _weights(self):
        if (self.by == "weights") != (self.weights is not None):
            raise ValueError("weights go with by = \"weights\", and it needs them")
        if self.weights is not None and (len(self.weights) != len(self.among) or sum(self.weights) <= 0):
            raise ValueError(f"weights: give {len(self.among)} weights (one per stage of among), not all 0; got "
                             f"{len(self.weights)} summing to {sum(self.weights):g}")
        if (self.rechoose is not None or self.rechoose_margin is not None) and self.by == "weights":
            raise ValueError("rechoose and rechoose_margin go with by = \"nearest\" or \"least_crowded\", not by = "
                             "\"weights\"")
        if self.rechoose_margin is not None and self.rechoose is None:
            raise ValueError("rechoose_margin goes with rechoose (seconds between two looks at the choice)")
        for j, o in enumerate(self.among):
            head = o[0] if isinstance(o, list) and o else o
            if self.by != "weights" and not isinstance(head, (GotoStageSpec, QueueStageSpec, LeaveStageSpec)):
                raise ValueError(f"among.{j}: by = {self.by!r} weighs each option by the place it leads to first, "
                                 f"but this branch " + ("is empty" if isinstance(head, list) else
                                                        f"begins with a {head.kind}")
                                 + ": begin it with a goto, queue or leave stage, or choose by weights")
        return self

    @property
    def branches(self) -> list[list]:
        """Each option as a list of stage specs (one stage as a branch of one)."""
        return [o if isinstance(o, list) else [o] for o in self.among]


StageSpec = Annotated[Union[GotoStageSpec, WaitStageSpec, QueueStageSpec, ChooseStageSpec, LeaveStageSpec],
                      Field(discriminator="kind")]
ChooseStageSpec.model_rebuild()


def _leaves(spec) -> bool:
    """Whether agents may leave the scene at a stage spec: a leave, or a choose with an
    option that ends with one."""
    if isinstance(spec, LeaveStageSpec):
        return True
    return isinstance(spec, ChooseStageSpec) and any(b and _leaves(b[-1]) for b in spec.branches)


def _coords(region) -> list:
    """Every coordinate a region table writes (its position, corners, centre, points), to
    check against the scene's dimension ([] for None)."""
    coords = [getattr(region, a) for a in ("position", "lower", "upper", "center") if hasattr(region, a)]
    return coords + list(getattr(region, "points", [])) + list(getattr(region, "positions", []))


def _stage_specs(route: list, where: str = "route"):
    """Every stage spec of a route with its field path, depth first: ``route.2``, then a
    choose's options ``route.2.among.0`` (one stage) or ``route.2.among.1.0`` (a branch's)."""
    for i, st in enumerate(route):
        yield f"{where}.{i}", st
        if isinstance(st, ChooseStageSpec):
            for j, o in enumerate(st.among):
                if isinstance(o, list):
                    yield from _stage_specs(o, f"{where}.{i}.among.{j}")
                else:
                    yield f"{where}.{i}.among.{j}", o


def _leave_last_lines(stages: list, where: str) -> list[str]:
    """A stage list's stages where agents leave the scene that are not its last."""
    out = []
    whose = "route's" if where == "route" else "branch's"
    for i, st in enumerate(stages):
        if isinstance(st, ChooseStageSpec):
            for j, o in enumerate(st.among):
                if isinstance(o, list):
                    out += _leave_last_lines(o, f"{where}.{i}.among.{j}")
        if i != len(stages) - 1 and _leaves(st):
            if isinstance(st, LeaveStageSpec):
                out.append(f"{where}.{i}: agents leave the scene at a leave stage, so it must be the {whose} last")
            else:
                j = next(j for j, b in enumerate(st.branches) if b and _leaves(b[-1]))
                out.append(f"{where}.{i}: agents taking among.{j} leave the scene, so the choose must be the last "
                           f"stage: move the stages after it to the end of the options that go on")
    return out
ROUTE_STAGES = (GotoStageSpec, WaitStageSpec, QueueStageSpec, ChooseStageSpec, LeaveStageSpec, WaitTimeSpec)


class GroupSpec(_Model):
    """A named set of agents: how many, where they start, where they go, their bodies.

    name : str          the group's name in outputs, reports and error messages
    count : int         number of agents
    spawn : table       where they start: a region table (point, points, rect, disc, ring, lattice);
                        left out when enter.entrances say where they come in
    goal : table        where they go: a region table (point, points, rect, disc, moving,
                        antipodal); required unless the group has a route
    radius : float      body radius, metres (bounding circle / sphere)
    max_speed : float   metres per second
    pref_speed : float  preferred walking speed, metres per second (≤ max_speed)
    personality : str   rvo: an OCEAN pole name (O+, O-, C+, C-, E+, E-, A+, A-, N+, N-),
                        a 5-vector of traits in [-1, 1], or a distribution table
    formation : table   formation: the group's template (see "Formation templates")
    enter : table       rvo, mdp, formation, pso: when (and where) they enter; off-scene
                        (not drawn, not avoided) until then. rvo, mdp: {start = s} (all
                        due then), {rate = persons/s, start = s, end = s} (all must fit
                        before end), {start = s, end = s} (spread evenly) or {times =
                        [s, ...]} (one per agent); each agent enters at a free point (rvo)
                        or free cell (mdp) of the spawn, waiting while there is none; with
                        entrances = [areas] (and weights, their shares of the group) in
                        place of the spawn, at one of its own entrance (drawn from the
                        seed; the first stands for the spawn). formation, pso: {start = s}
                        only, the whole formation or swarm coming in at its spawn once no
                        body stands there. mdp counts in steps of a dt fixed ahead (see
                        "journeys.md")
    route : list        rvo, formation, mdp, pso: the stages the agents follow in order
                        ([[groups.route]] tables: goto, wait, queue, choose, leave;
                        formation and mdp: all but queue; pso: goto, choose, leave; see
                        "Route stages"); the goal may then be left out
    attributes : table  method-specific extras (Python: Group.attributes), checked against the
                        method's own list (see "Group attributes"): rvo: pref_speed_range,
                        max_neighbors, neighbor_dist, samples, safety; formation: reassign,
                        heading_deg; mdp and pso take none
    """

    name: str = Field(min_length=1)
    count: Annotated[int, Field(gt=0, le=10_000_000)]
    spawn: RegionSpec | None = None
    goal: RegionSpec | None = None
    radius: PosFloat = 0.25
    max_speed: Speed = 1.5
    pref_speed: Speed = 1.3
    personality: str | list[float] | dict[str, Any] | None = None
    formation: TemplateSpec | None = None
    enter: EnterSpec | None = None
    route: Annotated[list[StageSpec], Field(min_length=1)] | None = None
    attributes: dict[str, Any] = {}

    @model_validator(mode="after")
    def _spawn_or_entrances(self):
        entrances = self.enter is not None and self.enter.entrances is not None
        if self.spawn is None and not entrances:
            raise ValueError("spawn: is missing: give the group a spawn region, or enter.entrances")
        if self.spawn is not None and entrances:
            raise ValueError("spawn: give a spawn or enter.entrances, not both: agents entering at entrances "
                             "start there")
        if self.enter is not None:
            from crowdmotion.journeys import check_enter

            check_enter(enter_attribute(self.enter), self.count)
        return self

    @model_validator(mode="after")
    def _goal_or_route(self):
        if self.goal is None and self.route is None:
            raise ValueError("goal: is missing: give the group a goal, or a route of stages")
        if self.route is not None:
            lines = _leave_last_lines(self.route, "route")
            if lines:
                raise ValueError(lines[0])
        return self

    @field_validator("personality")
    @classmethod
    def _personality(cls, v):
        if v is None:
            return v
        from crowdmotion.rvo.personality import sample_personalities

        sample_personalities(v, 1, np.random.default_rng(0))  # raises naming the bad entry
        return v


PLOTS = ("paths", "values", "snapshots", "player")  # what [output] plots may name
NAME_MAX = 100  # characters in a scenario's name


def check_name(name: str) -> str:
    """A scenario's name, which names its default output folder out/<name>: refused
    (ValueError) unless it is one plain folder name of printable characters."""
    if name in ("", ".", ".."):
        raise ValueError(f"a scenario name must name a folder, not {name!r}")
    if len(name) > NAME_MAX:
        raise ValueError(f"a scenario name must be at most {NAME_MAX} characters, got {len(name)}")
    sep = next((c for c in name if c in "/\\"), None)
    if sep is not None:
        raise ValueError(f"a scenario name must not contain the path separator {sep!r}")
    odd = next((c for c in name if not c.isprintable()), None)
    if odd is not None:
        raise ValueError(f"a scenario name must not contain control or other unprintable characters, "
                         f"found {odd!r}")
    return name


class OutputSpec(_Model):
    """What ``crowdmotion run`` writes beside summary.json.

    formats : list      trajectory files: "parquet" and/or "csv" (at least one)
    plots : list        pictures: "paths", "values" (mdp), "snapshots" (formation), "player"
                        (view.html)
    """

    formats: Annotated[list[Literal["parquet", "csv"]], Field(min_length=1)] = ["parquet"]
    plots: list[Literal[PLOTS]] = list(PLOTS)


class ScenarioSpec(_Model):
    """One scenario file: a scene, groups, a method and its parameters, a seed, outputs.

    name : str          the scenario's name (default output folder out/<name>): a plain
                        folder name, 1-100 printable characters, no slash or backslash,
                        not . or ..
    description : str   one line shown by ``crowdmotion scenarios`` and the demo
    method : str        "mdp", "rvo", "pso" or "formation"
    seed : int          random seed: the same seed gives the same trajectories
    scene : table       [scene]: bounds and obstacles
    groups : list       [[groups]]: one table per group of agents
    mdp : table         [mdp] parameters (only with method = "mdp")
    rvo : table         [rvo] parameters (only with method = "rvo")
    pso : table         [pso] parameters (only with method = "pso")
    formation : table   [formation] parameters (only with method = "formation")
    output : table      [output]: files and pictures to write
    """

    name: str = "scenario"
    description: str = ""
    method: Literal["mdp", "rvo", "pso", "formation"]
    seed: Annotated[int, Field(ge=0)] = 0
    scene: SceneSpec
    groups: list[GroupSpec] = Field(min_length=1)
    mdp: MDPParams = MDPParams()
    rvo: RVOParams = RVOParams()
    pso: PSOParams = PSOParams()
    formation: FormationParams = FormationParams()
    output: OutputSpec = OutputSpec()

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        return check_name(v)

    @field_validator("groups")
    @classmethod
    def _unique_names(cls, v):
        names = [g.name for g in v]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"group names must be unique, repeated: {sorted(dup)}")
        return v

    @model_validator(mode="after")
    def _dimensions(self):
        dim = len(self.scene.bounds[0])
        for i, g in enumerate(self.groups):
            for part in ("spawn", "goal"):
                for c in _coords(getattr(g, part)):
                    if len(c) != dim:
                        raise ValueError(f"groups.{i}.{part}: coordinates {c} are not {dim}D like the scene")
            for j, e in enumerate(g.enter.entrances if g.enter is not None and g.enter.entrances else []):
                if any(len(c) != dim for c in _coords(e)):
                    raise ValueError(f"groups.{i}.enter.entrances.{j}: coordinates are not {dim}D like the scene")
            for where, st in _stage_specs(g.route or [], f"groups.{i}.route"):
                if any(len(c) != dim for c in _coords(getattr(st, "area", None))):
                    raise ValueError(f"{where}.area: coordinates are not {dim}D like the scene")
        return self

    @model_validator(mode="after")
    def _special_regions(self):
        for i, g in enumerate(self.groups):
            if isinstance(g.goal, (RingRegion, LatticeRegion)):
                raise ValueError(f"groups.{i}.goal: a {g.goal.shape} is a spawn shape, not a goal")
            if isinstance(g.spawn, AntipodalRegion):
                raise ValueError(f"groups.{i}.spawn: 'antipodal' is a goal shape, not a spawn")
            if isinstance(g.goal, AntipodalRegion) and not isinstance(g.spawn, (RingRegion, PointsRegion, PointRegion)):
                raise ValueError(f"groups.{i}.goal: an antipodal goal needs fixed start points "
                                 f"(spawn shape ring, points or point), got "
                                 + (f"spawn shape {g.spawn.shape!r}" if g.spawn is not None else "enter.entrances"))
        return self


@dataclass
class Scenario:
    """A validated scenario: the spec plus the built Scene and Groups."""

    spec: ScenarioSpec
    scene: S.Scene
    groups: list[G.Group]
    source: Path | None = None

    @property
    def method(self) -> str:
        return self.spec.method

    @property
    def params(self):
        from crowdmotion.registry import method_params

        return method_params(self.spec.method, getattr(self.spec, self.spec.method).model_dump(exclude_unset=True))


PARAMS: dict[str, type[BaseModel]] = {"mdp": MDPParams, "rvo": RVOParams, "pso": PSOParams,
                                     "formation": FormationParams}


def _owners(key: str, tables: dict[str, type[BaseModel] | None], besides: str) -> list[str]:
    """The methods other than ``besides`` whose table in ``tables`` has a field ``key``."""
    return [m for m, model in tables.items() if m != besides and model is not None and key in model.model_fields]


def _close(key: str, names) -> str:
    close = difflib.get_close_matches(key, sorted(names), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def _unknown_key(loc: tuple, key: str) -> str | None:
    """What to say of an unknown ``key`` in the table at ``loc``: a method block's key
    that belongs to another method's block, or a near miss among this block's own keys; a
    group attribute (``heading_deg``) written in the group's table, not in its
    ``attributes`` (it was only "not a known field")."""
    if len(loc) == 1 and loc[0] in PARAMS:
        block = loc[0]
        owners = _owners(key, PARAMS, block)
        if owners:
            return (f"is not a [{block}] parameter: it belongs to " + " and ".join(f"[{m}]" for m in owners)
                    + _close(key, PARAMS[block].model_fields))
        return f"is not a [{block}] parameter{_close(key, field_names(PARAMS[block]))}"
    if len(loc) == 2 and loc[0] == "groups":  # a group attribute written in the group's own table
        readers = [m for m, model in ATTRIBUTES.items() if model is not None and key in model.model_fields]
        if readers:
            return (f"is not a [[groups]] field but a group attribute (method "
                    + " and ".join(repr(m) for m in readers) + f" {'reads' if len(readers) == 1 else 'read'} it): "
                    f"write it in the group's attributes table, attributes = {{ {key} = ... }}")
    if not loc and key not in ScenarioSpec.model_fields:  # a method's parameter written at the top
        blocks = {m: model.model_fields for m, model in PARAMS.items() if model is not None}
        names = set(ScenarioSpec.model_fields) | {k for fields in blocks.values() for k in fields}
        close = difflib.get_close_matches(key, sorted(names), n=1, cutoff=0.6)
        if close and close[0] not in ScenarioSpec.model_fields:
            owners = [m for m, fields in blocks.items() if close[0] in fields]
            return (f"is not a top-level field; did you mean {close[0]!r} in the "
                    + " or ".join(f"[{m}]" for m in owners) + " table?")
    return None


def _attribute_lines(attrs: dict, method: str, where: str) -> list[str]:
    """Problems with one group's ``attributes`` table under ``method``."""
    model = ATTRIBUTES[method]

    def about(key: str) -> str | None:
        owners = _owners(key, ATTRIBUTES, method)
        if owners:
            return (f"is not an attribute method {method!r} reads: it belongs to method "
                    + " and ".join(repr(m) for m in owners))
        if key in GroupSpec.model_fields:
            return "is a field of the group itself: write it in the [[groups]] table, not in attributes"
        if model is None:
            return f"is not an attribute: method {method!r} reads no group attributes"
        return None

    if model is None:
        return [f"{where}.{k}: {about(k)} (got {shown(v)})" for k, v in attrs.items()]
    try:
        model.model_validate(attrs, strict=True)
    except ValidationError as exc:
        return error_lines(exc, where, known=model.model_fields, hint=lambda loc, key: about(key))
    return []


#: the scene dimensions each method simulates in
METHOD_DIMENSIONS = {"mdp": (2, 3), "rvo": (2,), "pso": (2, 3), "formation": (2,)}


def _dimension_lines(data: Any) -> list[str]:
    """A 3D scene (bounds of 3 coordinates) under a 2D-only method, said as such and
    first: the spawn, obstacle and bounds errors that follow from it were all it said (a
    formation scene with 3D bounds failed on 'spawn coordinates [10.0, 0.0] are not 3D like
    the scene', then on '(Box) is 2D', never on the method)."""
    if not isinstance(data, dict) or data.get("method") not in METHOD_DIMENSIONS:
        return []
    scene = data.get("scene")
    bounds = scene.get("bounds") if isinstance(scene, dict) else None
    if not (isinstance(bounds, list) and bounds and isinstance(bounds[0], list)):
        return []
    method, dim, dims = data["method"], len(bounds[0]), METHOD_DIMENSIONS[data["method"]]
    if dim in dims or dim not in (2, 3):
        return []
    others = " or ".join(repr(m) for m, d in METHOD_DIMENSIONS.items() if dim in d)
    return [f"scene.bounds: method {method!r} works in " + " or ".join(f"{d}D" for d in dims) + f" only, but the "
            f"scene is {dim}D (scene.bounds has {dim} coordinates): give the bounds, obstacles, spawns, goals and "
            f"route areas {dims[0]} coordinates each, or set method = {others} for a {dim}D scene (got {shown(bounds)})"]


def _method_lines(data: Any) -> list[str]:
    """Fields the scenario's method does not read: another method's block, a group's
    ``personality`` or ``formation`` without that method, unknown or bad ``attributes``."""
    if not isinstance(data, dict) or data.get("method") not in METHODS:
        return []
    method = data["method"]
    lines = [f"{m}: a [{m}] table, but method = {shown(method)} reads only [{method}]: remove it "
             f"(or set method = {shown(m)})" for m in METHODS if m != method and m in data]
    groups = data.get("groups")
    for i, g in enumerate(groups if isinstance(groups, list) else []):
        if not isinstance(g, dict):
            continue
        for key, owners in GROUP_FIELD_METHOD.items():
            if key in g and method not in owners:
                lines.append(f"groups.{i}.{key}: only method " + " and ".join(shown(m) for m in owners)
                             + f" {'reads' if len(owners) == 1 else 'read'} a group's {key}, but method = "
                             f"{shown(method)} (got {shown(g[key])})")
        if method in UNIT_ENTRY and isinstance(g.get("enter"), dict):
            from crowdmotion.journeys import unit_entry_time

            try:
                unit_entry_time({k: v for k, v in g["enter"].items() if k != "start"}, f"groups.{i}.enter",
                                UNIT_ENTRY[method])
            except ValueError as exc:
                lines.append(str(exc))
        attrs = g.get("attributes")
        if isinstance(attrs, dict):
            lines += _attribute_lines(attrs, method, f"groups.{i}.attributes")
        lines += _route_lines(g.get("route"), method, f"groups.{i}.route")
    return lines


def _route_lines(route: Any, method: str, where: str) -> list[str]:
    """A route's (or a branch's) stages the scenario's method does not follow, each named."""
    if not isinstance(route, list):
        return []
    return [line for i, st in enumerate(route) for line in _stage_lines(st, method, f"{where}.{i}")]


def _stage_lines(stage: Any, method: str, at: str) -> list[str]:
    """A stage (at field path ``at``), and a choose's options, that the method does not follow."""
    takes = ROUTE_SUPPORT[method]
    kind = stage.get("kind") if isinstance(stage, dict) else None
    lines = []
    if kind in STAGE_KINDS and kind not in takes:
        why = "follows no route stages" if not takes else f"follows only {', '.join(takes)} stages"
        who = [repr(m) for m, kinds in ROUTE_SUPPORT.items() if kind in kinds]
        lines.append(f"{at}: a {kind!r} stage, but method {method!r} {why}; method "
                     + " and ".join(who) + (" follows" if len(who) == 1 else " follow") + f" {kind} stages")
    among = stage.get("among") if kind == "choose" else None
    for j, o in enumerate(among if isinstance(among, list) else []):
        lines += _route_lines(o, method, f"{at}.among.{j}") if isinstance(o, list) else \
            _stage_lines(o, method, f"{at}.among.{j}")
    return lines


# a union's branch in an error's place: groups.0.route.2.queue.rate -> groups.0.route.2.rate,
# route.0.among.1.branch.2.wait.time -> route.0.among.1.2.time
_OPTION_TAG = re.compile(r"\b(among\.\d+)\.(?:stage|branch)\b")
_STAGE_TAG = re.compile(r"\b((?:route|among)\.\d+(?:\.\d+)?)\.(?:goto|wait|queue|choose|leave)\b")
_AREA_TAG = re.compile(r"\b(route(?:\.(?:\d+|among))*\.area)\.(?:point|points|rect|disc)\b")
_TIME_TAG = re.compile(r"\.time\.(?:constrained-float|function-after\[[^\]]*\])")
# a check's own field at the head of its message: "groups.1: goal: is missing" -> "groups.1.goal: is missing"
_OWN_PART = re.compile(r"^(groups\.\d+[\w.]*): (goal|spawn|enter(?:\.\w+)*|route(?:\.\w+)+|among\.\d+|uniform|normal)(?:: | (?=must ))")


def _route_error_lines(lines: list[str]) -> list[str]:
    """Schema errors in a route in the file's own terms: no union branches in the
    field's place, and only the branch of a wait's time that the file wrote (a number
    or a table)."""
    out = []
    for line in lines:
        if ".time.constrained-float" in line and "(got {" in line:
            continue  # a table was written: the number branch's complaint is noise
        if ".time.function-after" in line and "valid dictionary or instance of WaitTimeSpec" in line:
            continue  # a number was written: likewise the table branch's
        line = _TIME_TAG.sub(".time", _AREA_TAG.sub(r"\1", _STAGE_TAG.sub(r"\1", _OPTION_TAG.sub(r"\1", line))))
        out.append(_OWN_PART.sub(r"\1.\2: ", line))
    return out


def _report(lines: list[str], source: str, data: Any = None) -> str:
    """``source: N problem(s)`` and one indented line per problem, groups named too."""
    groups = data.get("groups") if isinstance(data, dict) else None
    if isinstance(groups, list):  # name the group too: groups.0.radius (group 'walkers'): ...
        def named(m: re.Match) -> str:
            k = int(m.group(2))
            g = groups[k] if k < len(groups) else None
            name = g.get("name") if isinstance(g, dict) else None
            return f"{m.group(1)} (group {name!r}):" if isinstance(name, str) else m.group(0)
        lines = [re.sub(r"^(groups\.(\d+)[^:]*):", named, line) for line in lines]
    return "\n".join([f"{source}: {len(lines)} problem(s)"] + ["  " + line for line in lines])


def validate_spec(data: Any, source: str = "scenario") -> ScenarioSpec:
    """The scenario's schema checked on the data of a TOML file: strict types (``count =
    true`` and ``reassign = "no"`` are refused, not read as 1 and true), unknown fields
    with a suggestion, and fields the scenario's method does not read. Raises
    ScenarioError naming every bad field and value."""
    lines = []
    spec = None
    try:
        spec = ScenarioSpec.model_validate(data, strict=True)
    except ValidationError as exc:
        lines = error_lines(exc, known=field_names(ScenarioSpec), hint=_unknown_key, model=ScenarioSpec)
    except RecursionError:
        raise ScenarioError(f"{source}: tables or arrays nested too deeply to be a scenario") from None
    lines = _dimension_lines(data) + _route_error_lines(lines) + _method_lines(data)
    if lines:
        raise ScenarioError(_report(lines, source, data))
    return spec


def ring_points(center, radius: float, count: int, phase_deg: float = 0.0) -> np.ndarray:
    """``count`` points evenly spaced on a circle, the first at ``phase_deg``."""
    ang = np.deg2rad(phase_deg) + 2 * np.pi * np.arange(count) / count
    return np.asarray(center, dtype=float) + radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)


def _spawn(spec, count: int) -> Any:
    if isinstance(spec, RingRegion):
        return G.Points(ring_points(spec.center, spec.radius, count, spec.phase_deg))
    return _region(spec)


def _goal(spec, spawn) -> Any:
    if isinstance(spec, AntipodalRegion):
        return G.Points(2 * np.asarray(spec.center, dtype=float) - spawn.points)
    return _region(spec)


def _region(spec) -> Any:
    if isinstance(spec, PointRegion):
        return G.Points([spec.position])
    if isinstance(spec, PointsRegion):
        return G.Points(spec.points)
    if isinstance(spec, RectRegion):
        return G.Rect(spec.lower, spec.upper)
    if isinstance(spec, LatticeRegion):
        return G.Lattice(spec.lower, spec.upper)
    if isinstance(spec, DiscRegion):
        return G.Disc(spec.center, spec.radius)
    return G.MovingTarget(spec.times, spec.positions)


def _stage(spec, where: str):
    """A route stage's spec (at field path ``where``) as a :mod:`crowdmotion.stages`
    stage; ValueError naming the stage (``route.2.among.1.0: ...``)."""
    from crowdmotion import stages as R

    among = None
    if isinstance(spec, ChooseStageSpec):  # its options first, each named by its own path
        among = [_stages(o, f"{where}.among.{j}") if isinstance(o, list) else _stage(o, f"{where}.among.{j}")
                 for j, o in enumerate(spec.among)]
    try:
        if isinstance(spec, GotoStageSpec):
            return R.GoTo(_region(spec.area), spec.arrive, spec.name, spec.capacity)
        if isinstance(spec, LeaveStageSpec):
            return R.Leave(_region(spec.area), spec.name, spec.capacity)
        if isinstance(spec, WaitStageSpec):
            time = spec.time if not isinstance(spec.time, WaitTimeSpec) else spec.time.model_dump(exclude_none=True)
            return R.Wait(time, spec.name)
        if isinstance(spec, QueueStageSpec):
            return R.Queue(spec.head, spec.rate, spec.direction, spec.line, spec.spacing, spec.name, spec.capacity)
        margin = {} if spec.rechoose_margin is None else {"rechoose_margin": spec.rechoose_margin}
        return R.Choose(among, spec.by, spec.weights, spec.name, spec.rechoose, **margin)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _stages(specs: list, where: str) -> list:
    """A list of stage specs (a route, or a branch at ``where``) as stages."""
    return [_stage(st, f"{where}.{i}") for i, st in enumerate(specs)]


def route_stages(route: list) -> list:
    """A group's route specs as stages; ValueError naming the stage (``route.2: ...``)."""
    return _stages(route, "route")


def _first_place(stages: list, spawn) -> Any:
    """Where a route leads first (its group's goal for the checks and reports that read
    one): the first area or queue head on it (depth first), else the spawn."""
    from crowdmotion.stages import Queue, flat_stages

    for _, st, _ in flat_stages(stages):
        if isinstance(st, Queue):
            return G.Points(st.head[None])
        if hasattr(st, "area"):
            return st.area
    return spawn


def _attributes(g: GroupSpec) -> dict:
    out = dict(g.attributes)
    if g.personality is not None:
        out["personality"] = g.personality
    if g.formation is not None:
        out["formation"] = g.formation
    if g.enter is not None:
        out["enter"] = enter_attribute(g.enter)
    return out


def enter_attribute(spec: EnterSpec) -> dict:
    """A group's ``enter`` table as ``Group.attributes["enter"]``: the keys written, with
    entrances as regions."""
    out = spec.model_dump(exclude_none=True, exclude_unset=True)
    if spec.entrances is not None:
        out["entrances"] = [_region(e) for e in spec.entrances]
    return out


def _obstacle(spec) -> S.Obstacle:
    path = None if spec.path is None else (spec.path.times, spec.path.positions)
    if isinstance(spec, CircleSpec):
        return S.Circle(spec.center, spec.radius, path=path)
    if isinstance(spec, SphereSpec):
        return S.Sphere(spec.center, spec.radius, path=path)
    if isinstance(spec, BoxSpec):
        return S.Box(spec.lower, spec.upper, path=path)
    return S.Polygon(spec.vertices, path=path)


# the parameters that bound a run's length, per method (named when a run would not fit)
STEPS_FIELD = {"mdp": "mdp.max_steps", "rvo": "rvo.max_steps", "pso": "pso.iterations",
               "formation": "formation.max_steps"}
STEP_FIELD = {"mdp": "mdp.cell_size", "rvo": "rvo.time_step", "pso": "pso.iteration_time",
              "formation": "formation.time_step"}
MAX_DURATION_S = 86_400.0  # simulated seconds a run may last at most: a day


@dataclass(frozen=True)
class SizeEstimate:
    """Upper bounds of a run, from the groups' counts and the method's parameters alone:
    ``agents``, ``steps`` simulated, ``seconds`` simulated, ``frames`` in its trajectories
    and the ``bytes`` its positions take in memory (the raw steps and, when resampled or
    relaxed, the output frames)."""

    agents: int
    steps: int
    seconds: float
    frames: int
    bytes: int


def size_estimate(scenario: Scenario) -> SizeEstimate:
    """What a run of ``scenario`` holds at most, without placing a single agent."""
    from crowdmotion.registry import get_method

    module = get_method(scenario.method).module
    params = scenario.params
    n = sum(g.count for g in scenario.groups)
    steps = int(module.expected_steps(scenario.groups, params))
    seconds = steps * float(module.step_seconds(scenario.groups, params))
    frames = int(module.expected_frames(scenario.groups, params))
    copy = getattr(module, "output_copy", None)  # output frames kept beside the steps, at the steps' rate
    separate = frames != steps + 1 or (copy is not None and copy(params))
    held = steps + 1 + (frames if separate else 0)
    return SizeEstimate(n, steps, seconds, frames, held * n * scenario.scene.dim * 8)


def _check_size(scenario: Scenario, source: str, max_memory: int | None) -> None:
    """Refuse a run longer than a simulated day, or whose trajectories would not fit in
    ``max_memory`` bytes (default: the memory available now), before any agent is placed."""
    from crowdmotion.memory import available_memory, human_bytes

    est = size_estimate(scenario)
    if est.seconds > MAX_DURATION_S:
        m = scenario.method
        raise ScenarioError(f"{source}: a run may last {est.steps:,} steps of {est.seconds / est.steps:.3g} s = "
                            f"{est.seconds:.3g} s of simulated time, more than a day ({MAX_DURATION_S:g} s): lower "
                            f"{STEPS_FIELD[m]} or {STEP_FIELD[m]}")
    limit = available_memory() if max_memory is None else int(max_memory)
    if limit is None:
        return
    if est.bytes > limit:
        what = "the memory available now" if max_memory is None else "the most allowed (--max-memory)"
        raise ScenarioError(f"{source}: a run would hold up to {human_bytes(est.bytes)} of trajectories "
                            f"({est.agents:,} agents x {est.steps:,} steps, {est.frames:,} frames), more than "
                            f"{human_bytes(limit)}, {what}: lower the groups' count or "
                            f"{STEPS_FIELD[scenario.method]}")


MAX_PLAUSIBLE_SPEED = 50.0  # m/s: a group given more wrote its speeds in another unit (130 for 1.3 m/s)


def _warn_outside(scene: S.Scene, source: str) -> None:
    """Warn of a still obstacle lying wholly outside the scene's bounds: it changes nothing
    (a coordinate mistyped, a wall the user thinks is there)."""
    for i, ob in enumerate(scene.obstacles):
        if ob.is_moving:
            continue
        lo, hi = ob.bounds()
        if np.any(hi <= scene.lower) or np.any(lo >= scene.upper):
            warnings.warn(f"{source}: scene.obstacles.{i} ({np.round(lo, 3).tolist()}-{np.round(hi, 3).tolist()}) "
                          f"lies wholly outside the scene bounds {scene.lower.tolist()}-{scene.upper.tolist()}: "
                          f"it changes nothing (a coordinate mistyped?)", stacklevel=3)


def _warn_speeds(spec: ScenarioSpec, source: str) -> None:
    """Warn of a group's speed beyond ``MAX_PLAUSIBLE_SPEED``: speeds are metres per second."""
    for i, g in enumerate(spec.groups):
        for key in ("pref_speed", "max_speed"):
            value = getattr(g, key)
            if value is not None and value > MAX_PLAUSIBLE_SPEED:
                warnings.warn(f"{source}: groups.{i}.{key} = {value:g} m/s: speeds are metres per second (a "
                              f"walker about 1.3, a car in town about 14); {value:g} would be "
                              f"{value * 3.6:g} km/h", stacklevel=3)


#: a spawn area this much of which lies in obstacles or outside the bounds is worth a warning
SPAWN_BLOCKED_WARN = 0.1


def _warn_spawn_blocked(scene: S.Scene, spec: ScenarioSpec, groups: list, source: str) -> None:
    """Warn of a group's spawn area (a rect or disc) lying largely inside obstacles (at
    t = 0) or outside the bounds: its agents are placed in the rest, which may not be what
    the file meant (a corner mistyped). Judged on 4000 points spread over the area."""
    rng = np.random.default_rng(0)
    for i, (g, group) in enumerate(zip(spec.groups, groups)):
        region = group.spawn
        if g.spawn is None or not isinstance(region, (G.Rect, G.Disc)) or isinstance(region, G.Lattice):
            continue
        pts = region.sample(4000, rng)
        blocked = (scene.obstacle_distance(pts, 0.0) < 0) | (scene.wall_clearance(pts) < 0)
        share = float(blocked.mean())
        if SPAWN_BLOCKED_WARN <= share < 1.0:
            warnings.warn(f"{source}: groups.{i}.spawn: {share:.0%} of its area lies inside obstacles or outside the "
                          f"scene bounds; its agents are placed in the rest (a corner mistyped?)", stacklevel=3)


def build(spec: ScenarioSpec, source: str = "scenario", max_memory: int | None = None) -> Scenario:
    """Turn a validated spec into Scene and Groups; shape errors name the field. A run
    that would not fit in ``max_memory`` bytes (default: the memory available now) is
    refused before the method checks the scenario."""
    obstacles = []
    for i, o in enumerate(spec.scene.obstacles):
        try:
            obstacles.append(_obstacle(o))
        except ValueError as exc:
            raise ScenarioError(f"{source}: scene.obstacles.{i}: {exc}") from None
    try:
        scene = S.Scene(bounds=spec.scene.bounds, obstacles=obstacles)
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"{source}: scene: {exc}") from None
    _warn_outside(scene, source)
    groups = []
    for i, g in enumerate(spec.groups):
        try:
            # entering at entrances, the first stands for the spawn where one is read
            spawn = _spawn(g.spawn, g.count) if g.spawn is not None else _region(g.enter.entrances[0])
            attributes = _attributes(g)
            if g.route is not None:
                attributes["route"] = route_stages(g.route)
            goal = _goal(g.goal, spawn) if g.goal is not None else _first_place(attributes["route"], spawn)
            groups.append(G.Group(name=g.name, count=g.count, spawn=spawn, goal=goal,
                                  radius=g.radius, max_speed=g.max_speed, pref_speed=g.pref_speed,
                                  attributes=attributes))
        except ValueError as exc:
            raise ScenarioError(f"{source}: groups.{i}: {exc}") from None
    _warn_speeds(spec, source)
    _warn_spawn_blocked(scene, spec, groups, source)
    scenario = Scenario(spec, scene, groups)
    try:
        params = scenario.params  # validates the method block once more, in the method's terms
        _check_size(scenario, source, max_memory)
        from crowdmotion.registry import get_method

        check = getattr(get_method(spec.method).module, "check_scenario", None)
        if check is not None:
            check(scene, groups, params)
    except ScenarioError:
        raise
    except ValueError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    return scenario


def parse_scenario(text: str, source: str = "scenario", max_memory: int | None = None) -> Scenario:
    """Validate TOML text; raises ScenarioError naming every bad field and value.
    ``max_memory``: bytes a run's trajectories may take (default: the memory available now)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ScenarioError(f"{source}: tables or arrays nested too deeply to be a scenario") from None
    return build(validate_spec(data, source), source, max_memory)


def load_scenario(path, max_memory: int | None = None) -> Scenario:
    """Read and validate a scenario file (``max_memory``: see :func:`parse_scenario`)."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"no scenario file at {path}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read: {exc}") from None
    sc = parse_scenario(text, str(path), max_memory)
    sc.source = path
    return sc


@dataclass
class RunResult:
    """What :func:`run_scenario` gives back: trajectories, the method's extras, metrics."""

    scenario: Scenario
    trajectories: Any
    extras: Any
    summary: dict
    seed: int


def run_scenario(scenario, seed: int | None = None, progress: bool = True, precompile: bool = False) -> RunResult:
    """Run a scenario (object or path) with its method; metrics are computed on the result.

    ``precompile``: on a cold numba cache, compile the run's kernels on every core first,
    in forked children (:mod:`crowdmotion._precompile`; the command line asks for it). A
    library call forks nothing unless asked: numba compiles what the run calls, in this
    process."""
    from crowdmotion.registry import get_method

    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    seed = scenario.spec.seed if seed is None else int(seed)
    if seed < 0:
        raise ScenarioError(f"seed must be a non-negative integer, got {seed}")
    method = get_method(scenario.method)
    if precompile:
        from crowdmotion._precompile import start

        start(scenario.method)
    rng = np.random.default_rng(seed)
    traj, extras, summary = method.run(scenario.scene, scenario.groups, scenario.params, rng, progress=progress)
    traj.metadata.update({"seed": seed, "scenario": scenario.spec.name})
    summary["partial"] = bool(traj.metadata.get("partial", False))  # Ctrl-C stopped it: the frames so far
    fps = getattr(scenario.params, "fps", None)
    if traj.n_frames < 2 and not summary["partial"] and fps:
        warnings.warn(f"{scenario.method}.fps = {fps:g} keeps one frame of the run: its files show nobody "
                      f"moving (give at least the frames a second its length needs for two)", stacklevel=2)
    return RunResult(scenario, traj, extras, summary, seed)
