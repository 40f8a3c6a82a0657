"""Scenario TOML files: schema (pydantic), loading with field-named errors, and running.

A scenario is one TOML file: ``[scene]`` (bounds, obstacles), ``[[groups]]``,
``method`` with its own parameter block (``[mdp]``, ``[rvo]``, ``[pso]``, ``[formation]``), ``seed`` and ``[output]``. Nothing
in the file is ever executed. Each method adds its block here without changing the rest.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from crowdmotion import groups as G
from crowdmotion._validation import error_lines, field_names
from crowdmotion.formation.params import FormationParams, TemplateSpec
from crowdmotion.mdp.params import MDPParams
from crowdmotion.pso.params import PSOParams
from crowdmotion.rvo.params import RVOParams
from crowdmotion import scene as S


class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message names each bad field and value."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


Coord = Annotated[list[float], Field(min_length=2, max_length=3)]
PosFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class PathSpec(_Model):
    """A keyframed path: the obstacle's centre moves through ``positions`` at ``times``,
    linearly between keyframes (held before the first and after the last).

    times : list       keyframe times, seconds, increasing
    positions : list   one [x, y] or [x, y, z] centre per keyframe, metres
    """

    times: list[Annotated[float, Field(allow_inf_nan=False)]]
    positions: list[Coord]


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
    vertices: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=3)
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
    """Listed points: one start per agent (spawn), or goal points (one, or one per agent).

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
    times: list[Annotated[float, Field(allow_inf_nan=False)]]
    positions: list[Coord]


class RingRegion(_Model):
    """Spawn only: the group's agents evenly spaced on a circle (the antipodal-circle scene).

    shape : str        "ring"
    center : list      [x, y] centre, metres
    radius : float     metres
    phase_deg : float  angle of the first agent, degrees
    """

    shape: Literal["ring"]
    center: Annotated[list[float], Field(min_length=2, max_length=2)]
    radius: PosFloat
    phase_deg: Annotated[float, Field(allow_inf_nan=False)] = 0.0


class AntipodalRegion(_Model):
    """Goal only: each agent heads for the mirror image of its start through ``center``.

    shape : str        "antipodal"
    center : list      the mirror point, metres
    """

    shape: Literal["antipodal"]
    center: Coord


RegionSpec = Annotated[Union[PointRegion, PointsRegion, RectRegion, DiscRegion, MovingRegion, RingRegion,
                             AntipodalRegion], Field(discriminator="shape")]


class GroupSpec(_Model):
    """A named set of agents: how many, where they start, where they go, their bodies.

    name : str          the group's name in outputs, reports and error messages
    count : int         number of agents
    spawn : table       where they start: a region table (point, points, rect, disc, ring)
    goal : table        where they go: a region table (point, points, rect, disc, moving,
                        antipodal)
    radius : float      body radius, metres (bounding circle / sphere)
    max_speed : float   metres per second
    pref_speed : float  preferred walking speed, metres per second (≤ max_speed)
    personality : str   rvo: an OCEAN pole name (O+, O-, C+, C-, E+, E-, A+, A-, N+, N-),
                        a 5-vector of traits in [-1, 1], or a distribution table
    formation : table   formation: the group's template (see "Formation templates")
    attributes : table  method-specific extras passed through to the method (Python:
                        Group.attributes), e.g. rvo: pref_speed_range = [low, high]
                        (each agent's speed drawn uniformly, RiMEA test 7), heading_deg
    """

    name: str = Field(min_length=1)
    count: Annotated[int, Field(gt=0, le=10_000_000)]
    spawn: RegionSpec
    goal: RegionSpec
    radius: PosFloat = 0.25
    max_speed: PosFloat = 1.5
    pref_speed: PosFloat = 1.3
    personality: str | list[float] | dict[str, Any] | None = None
    formation: TemplateSpec | None = None
    attributes: dict[str, Any] = {}

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

    formats : list      trajectory files: "parquet" and/or "csv"
    plots : list        pictures: "paths", "values" (mdp), "snapshots" (formation), "player"
                        (view.html)
    """

    formats: list[Literal["parquet", "csv"]] = ["parquet"]
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
    mdp : table         [mdp] parameters (used when method = "mdp")
    rvo : table         [rvo] parameters (used when method = "rvo")
    pso : table         [pso] parameters (used when method = "pso")
    formation : table   [formation] parameters (used when method = "formation")
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
                region = getattr(g, part)
                coords = [getattr(region, a) for a in ("position", "lower", "upper", "center") if hasattr(region, a)]
                coords += list(getattr(region, "points", [])) + list(getattr(region, "positions", []))
                for c in coords:
                    if len(c) != dim:
                        raise ValueError(f"groups.{i}.{part}: coordinates {c} are not {dim}D like the scene")
        return self

    @model_validator(mode="after")
    def _special_regions(self):
        for i, g in enumerate(self.groups):
            if isinstance(g.goal, RingRegion):
                raise ValueError(f"groups.{i}.goal: a ring is a spawn shape, not a goal")
            if isinstance(g.spawn, AntipodalRegion):
                raise ValueError(f"groups.{i}.spawn: 'antipodal' is a goal shape, not a spawn")
            if isinstance(g.goal, AntipodalRegion) and not isinstance(g.spawn, (RingRegion, PointsRegion, PointRegion)):
                raise ValueError(f"groups.{i}.goal: an antipodal goal needs fixed start points "
                                 f"(spawn shape ring, points or point), got spawn shape {g.spawn.shape!r}")
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

        return method_params(self.spec.method, getattr(self.spec, self.spec.method).model_dump())


def _fmt_errors(err: ValidationError, source: str, data: dict | None = None) -> str:
    lines = error_lines(err, known=field_names(ScenarioSpec))
    groups = (data or {}).get("groups")
    if isinstance(groups, list):  # name the group too: groups.0.radius (group 'walkers'): ...
        def named(m: re.Match) -> str:
            k = int(m.group(2))
            g = groups[k] if k < len(groups) else None
            name = g.get("name") if isinstance(g, dict) else None
            return f"{m.group(1)} (group {name!r}):" if isinstance(name, str) else m.group(0)
        lines = [re.sub(r"^(groups\.(\d+)[^:]*):", named, line) for line in lines]
    return "\n".join([f"{source}: {err.error_count()} problem(s)"] + ["  " + line for line in lines])


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
    if isinstance(spec, DiscRegion):
        return G.Disc(spec.center, spec.radius)
    return G.MovingTarget(spec.times, spec.positions)


def _attributes(g: GroupSpec) -> dict:
    out = dict(g.attributes)
    if g.personality is not None:
        out["personality"] = g.personality
    if g.formation is not None:
        out["formation"] = g.formation
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


def build(spec: ScenarioSpec, source: str = "scenario") -> Scenario:
    """Turn a validated spec into Scene and Groups; shape errors name the field."""
    try:
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
        groups = []
        for i, g in enumerate(spec.groups):
            try:
                spawn = _spawn(g.spawn, g.count)
                groups.append(G.Group(name=g.name, count=g.count, spawn=spawn, goal=_goal(g.goal, spawn),
                                      radius=g.radius, max_speed=g.max_speed, pref_speed=g.pref_speed,
                                      attributes=_attributes(g)))
            except ValueError as exc:
                raise ScenarioError(f"{source}: groups.{i}: {exc}") from None
        scenario = Scenario(spec, scene, groups)
        try:
            params = scenario.params  # validates the method block once more, in the method's terms
            from crowdmotion.registry import get_method

            check = getattr(get_method(spec.method).module, "check_scenario", None)
            if check is not None:
                check(scene, groups, params)
        except ValueError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
        return scenario
    except ScenarioError:
        raise


def parse_scenario(text: str, source: str = "scenario") -> Scenario:
    """Validate TOML text; raises ScenarioError naming every bad field and value."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    try:
        spec = ScenarioSpec.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_fmt_errors(exc, source, data)) from None
    return build(spec, source)


def load_scenario(path) -> Scenario:
    """Read and validate a scenario file."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"no scenario file at {path}")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read: {exc}") from None
    sc = parse_scenario(text, str(path))
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


def run_scenario(scenario, seed: int | None = None, progress: bool = True) -> RunResult:
    """Run a scenario (object or path) with its method; metrics are computed on the result."""
    from crowdmotion.registry import get_method

    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    seed = scenario.spec.seed if seed is None else int(seed)
    if seed < 0:
        raise ScenarioError(f"seed must be a non-negative integer, got {seed}")
    method = get_method(scenario.method)
    from crowdmotion._precompile import start as precompile

    precompile(scenario.method)  # a cold cache: the run's kernels compiled on every core first
    rng = np.random.default_rng(seed)
    traj, extras, summary = method.run(scenario.scene, scenario.groups, scenario.params, rng, progress=progress)
    traj.metadata.update({"seed": seed, "scenario": scenario.spec.name})
    summary["partial"] = bool(traj.metadata.get("partial", False))  # Ctrl-C stopped it: the frames so far
    return RunResult(scenario, traj, extras, summary, seed)
