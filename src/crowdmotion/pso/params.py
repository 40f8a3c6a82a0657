"""Parameters of the particle-swarm method: one pydantic model, used as the scenario's
``[pso]`` block and by the Python API alike, so both validate the same way."""

from __future__ import annotations

import math
import warnings
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from crowdmotion._validation import Coordinate, MethodParams, NonNegative, Positive

PosFloat = Positive
NonNeg = NonNegative
Coord = Annotated[list[Coordinate], Field(min_length=2, max_length=3)]
STAGES = ("goto", "choose", "leave")  # the route stages a swarm follows (validate reads it too)
MAX_ITERATION_TIME_S = 10.0  # seconds per iteration at most
MAX_FPS = 1000.0  # output frames per second at most


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ObstacleField(_Model):
    """Sphere (3D) / circle (2D) obstacles generated from the seed, as in the paper's panel.

    ``layout = "random"`` scatters ``count`` obstacles of ``radius`` uniformly over the
    region between the start range and the target; ``"grouped"`` places them in
    ``clusters`` clumps of ``spread`` metres around random cluster centres. ``lower`` /
    ``upper`` bound the region (default: the box spanned by the groups' spawn regions and
    targets). Obstacles never cover a target or a spawn point: they keep ``clear`` metres
    (default: radius + threshold + 1) from each target.

    count : int        obstacles to generate
    radius : float     each obstacle's radius, metres
    layout : str       "random" or "grouped"
    clusters : int     with "grouped": how many clumps
    spread : float     with "grouped": metres round each clump's centre (None: 3 × radius)
    lower : list       lowest corner of the region (None: from the spawns and targets)
    upper : list       highest corner of the region
    clear : float      metres kept free round each target (None: radius + threshold + 1)
    """

    count: Annotated[int, Field(gt=0, le=100_000)]
    radius: PosFloat
    layout: Literal["random", "grouped"] = "random"
    clusters: Annotated[int, Field(gt=0, le=10_000)] = 3
    spread: PosFloat | None = None
    lower: Coord | None = None
    upper: Coord | None = None
    clear: NonNeg | None = None


class PSOParams(MethodParams, _Model):
    """The particle-swarm method's parameters; defaults are the paper's (§3, Fig. 4).

    iterations : int          [k] iterations per target update (gathering: in all)
    w, c1, c2 : float         inertia and acceleration constants; w = 1 is the 1995 form
    constriction : bool       Clerc's constriction χ = 2/|2 − φ − √(φ² − 4φ)|, φ = c1 + c2 > 4
    v_max : float | [float]   velocity clamp, units per iteration: one number for every axis, or one an axis (2D uses x, y)
    threshold : float         a particle this close to its target stops
    iteration_time : float    seconds per iteration (the path's time base)
    fps : float | None        output frame rate (None: one frame per iteration)
    smoothing : str           "relaxed" (default): the paths relaxed at ``fps`` for smooth
                              root motion (smoothed over ``smoothing_window`` and kept apart,
                              see ``crowdmotion.path_relaxation``; audited in continuous time,
                              a step that would touch keeps its straight move); "linear": the
                              iterates themselves, straight moves between them (the paper's)
    smoothing_window : float  seconds the "relaxed" paths are averaged over
    avoid_obstacles : bool    the redirect rule, eqs. (4)–(5), against obstacles
    detection : float         obstacle detection range: clearance, metres
    avoid_agents : bool       the same rule against other particles, nearest-to-target first
    avoid_radius : float      [r] particles within this distance are considered
    avoid_angle_deg : float   [θ] ... if their direction is within θ of the velocity
    separation : bool         the final separation step (moves cut short before a contact)
    join_gap : float          with avoid_agents: a particle this close to a gathered particle
                              of its group, inside the group's gathering radius, has gathered
                              too (the group arrival rule, see ``swarm.gather_radius``)
    gather_slack : float      the gathering radius is threshold + slack × the radius of the
                              ball the group's bodies fill when densely packed
    stall_iterations : int    a swarm whose best has not come nearer its target for this
                              many iterations, none of it arrived, is pulled at the target
                              itself (g ← target) until it finds a better best; 0 = off
    stop_when_done : bool     end a gathering once every particle has stopped
    max_iterations : int      hard cap on iterations in one run
    spawn_gap : float         extra clearance between sampled start positions
    obstacle_field : ObstacleField | None  obstacles generated from the seed
    """

    error_prefix = "pso"

    iterations: Annotated[int, Field(gt=0, le=1_000_000)] = 100
    w: NonNeg = 1.0
    c1: NonNeg = 2.0
    c2: NonNeg = 2.0
    constriction: bool = False
    v_max: Annotated[list[PosFloat], Field(min_length=1, max_length=3)] = [0.5, 0.5, 0.5]
    threshold: PosFloat = 0.5
    iteration_time: Annotated[float, Field(gt=0, le=MAX_ITERATION_TIME_S, allow_inf_nan=False)] = 0.25
    fps: Annotated[float, Field(gt=0, le=MAX_FPS, allow_inf_nan=False)] | None = 24.0
    smoothing: Literal["relaxed", "linear"] = "relaxed"
    smoothing_window: Annotated[float, Field(gt=0, le=60.0, allow_inf_nan=False)] = 1.5
    avoid_obstacles: bool = True
    detection: NonNeg = 1.0
    avoid_agents: bool = True
    avoid_radius: PosFloat = 1.0
    avoid_angle_deg: Annotated[float, Field(gt=0, le=180, allow_inf_nan=False)] = 45.0
    separation: bool = True
    join_gap: NonNeg = 0.25
    gather_slack: Annotated[float, Field(ge=1, allow_inf_nan=False)] = 1.5
    stall_iterations: Annotated[int, Field(ge=0, le=1_000_000)] = 25
    stop_when_done: bool = True
    max_iterations: Annotated[int, Field(gt=0, le=10_000_000)] = 100_000
    spawn_gap: NonNeg = 0.05
    obstacle_field: ObstacleField | None = None

    @field_validator("v_max", mode="before")
    @classmethod
    def _one_v_max(cls, v):
        """A single number for every axis, as ``[v]`` (docs/pso.md: "one value applies to
        every axis"; ``v_max = 0.5`` was refused as not a list, only ``[0.5]`` passed),
        still finite and positive; a list is checked entry by entry."""
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            if not math.isfinite(v) or v <= 0:
                raise ValueError("must be a finite number more than 0 (m an axis per iteration)")
            return [v]
        if isinstance(v, (list, tuple)) and 1 <= len(v) <= 3:
            return v
        raise ValueError("must be a number for every axis or a list of 1 to 3 numbers, one an axis, e.g. 0.5 or "
                         "[0.5, 0.5, 0.3]")

    @model_validator(mode="after")
    def _constriction(self):
        if self.constriction and self.c1 + self.c2 <= 4:
            raise ValueError(f"constriction needs c1 + c2 > 4 (e.g. 2.05 each), got c1={self.c1}, c2={self.c2}")
        return self

    @property
    def chi(self) -> float:
        """The constriction factor (1 without constriction)."""
        if not self.constriction:
            return 1.0
        phi = self.c1 + self.c2
        return 2.0 / abs(2.0 - phi - math.sqrt(phi * phi - 4.0 * phi))

    def axis_vmax(self, dim: int) -> list[float]:
        """v_max for ``dim`` axes: a single value applies to every axis."""
        v = list(self.v_max)
        if len(v) == 1:
            return v * dim
        if len(v) < dim:
            raise ValueError(f"pso.v_max has {len(v)} entries but the scene is {dim}D, got {v}")
        return v[:dim]


def make_params(params: PSOParams | None = None, **overrides) -> PSOParams:
    """``params`` with ``overrides`` applied; errors name ``pso.field`` and the value
    (:class:`~crowdmotion._validation.MethodParams`)."""
    base = {} if params is None else params.model_dump()
    return PSOParams(**{**base, **overrides})


def warn_fast_clamp(scene, groups, params: PSOParams) -> None:
    """The paper's clamp is per axis and per iteration: say so when it lets a particle
    move faster than its group's max_speed (the default v_max, 0.5 m an axis every
    0.25 s, allows 3.46 m/s in 3D)."""
    from crowdmotion.checks import where  # here: loading the parameters need not load checks' placement code

    top = float(np.linalg.norm(params.axis_vmax(scene.dim))) / params.iteration_time
    for i, g in enumerate(groups):
        if top > g.max_speed * (1 + 1e-9):
            warnings.warn(f"{where(i, g)}: pso.v_max {params.axis_vmax(scene.dim)} per "
                          f"{params.iteration_time:g} s iteration lets a particle move at up to {top:.2f} m/s, above "
                          f"the group's max_speed {g.max_speed:g} m/s (PSO clamps per axis, as the paper does); "
                          f"lower pso.v_max or raise pso.iteration_time to keep to it", stacklevel=3)
