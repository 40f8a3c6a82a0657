"""Parameters of the guiding-mesh formation method and its formation templates: pydantic
models shared by the scenario's ``[formation]`` block, a group's ``formation`` table and
the Python API, so all three validate the same way."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, model_validator

from crowdmotion._validation import Coordinate, MethodParams, NonNegative, Positive

PosFloat = Positive
NonNeg = NonNegative
Count = Annotated[int, Field(gt=0, le=1_000_000)]
STAGES = ("goto", "wait", "choose", "leave")  # the route stages a formation follows (validate reads it too)
MAX_TIME_STEP_S = 10.0  # seconds per step at most
MAX_FPS = 1000.0  # output frames per second at most
Fps = Annotated[float, Field(gt=0, le=MAX_FPS, allow_inf_nan=False)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BlockTemplate(_Model):
    """A rectangular block: ``rows`` ranks one behind the other, ``cols`` files across.

    kind : str         "block"
    rows : int         ranks, one behind the other
    cols : int         files across the direction of travel
    spacing : float    metres between neighbours
    """

    kind: Literal["block"]
    rows: Count
    cols: Count
    spacing: PosFloat = 1.0


class WedgeTemplate(_Model):
    """A wedge (arrow head) pointing forward: row k holds 2k + 1 agents.

    kind : str         "wedge"
    rows : int         rows from the tip back (rows² agents in all)
    spacing : float    metres between neighbours
    """

    kind: Literal["wedge"]
    rows: Count
    spacing: PosFloat = 1.0


class CircleTemplate(_Model):
    """``count`` agents evenly spaced on a circle of ``radius``.

    kind : str         "circle"
    count : int        agents on the circle (at least 3)
    radius : float     metres
    """

    kind: Literal["circle"]
    count: Annotated[int, Field(ge=3, le=1_000_000)]
    radius: PosFloat


class LineTemplate(_Model):
    """``count`` agents abreast in one line across the direction of travel.

    kind : str         "line"
    count : int        agents in the line
    spacing : float    metres between neighbours
    """

    kind: Literal["line"]
    count: Count
    spacing: PosFloat = 1.0


class CarsTemplate(_Model):
    """Traffic: ``lanes`` × ``per_lane`` cars, each car two agents ``car_width`` apart
    side by side (the car's heading is the angle of the pair plus 90°).

    kind : str         "cars"
    lanes : int        lanes side by side
    per_lane : int     cars one behind the other in each lane
    car_width : float  metres between a car's two agents
    car_gap : float    metres from one car to the next in its lane
    lane_width : float  metres between lane centres
    """

    kind: Literal["cars"]
    lanes: Count
    per_lane: Count
    car_width: PosFloat = 1.8
    car_gap: PosFloat = 6.0
    lane_width: PosFloat = 3.5


class PointsTemplate(_Model):
    """Any point set, in the formation's own frame (x forward, y to the left).

    kind : str         "points"
    points : list      [x, y] of each agent, metres
    """

    kind: Literal["points"]
    points: list[Annotated[list[Coordinate], Field(min_length=2, max_length=2)]] = Field(min_length=1)


TemplateSpec = Annotated[Union[BlockTemplate, WedgeTemplate, CircleTemplate, LineTemplate, CarsTemplate,
                               PointsTemplate], Field(discriminator="kind")]


class FormationParams(MethodParams, _Model):
    """The formation method's parameters (Li & He 2017); the paper gives no numbers, so
    the defaults are ours, chosen for walking groups in metres and seconds.

    time_step : float          [Δt] seconds per simulation step
    max_steps : int            steps before the run stops (it stops earlier once every
                               group has reached its target area and recovered)
    fps : float | None         output frame rate (None: one frame per step)
    field_range : float        [r] obstacle potential field range, eq. (2), metres
    field_cell : float         edge of the uniform environment grid holding the field
    repulsion : float          speed a vertex gets from the field at f = 1, as a multiple
                               of the group's preferred speed
    arap : str                 "two_step" (Igarashi et al. 2005, eq. 1) or "average"
                               (the paper's cheap variant: the mean of the positions the
                               fitted triangles propose)
    shape_gain : float         [1/s] with handles = "exact": how fast free vertices close
                               the gap to their as-rigid-as-possible position ("speed
                               set by the error")
    anchor_weight : float      weight of the soft pull of every vertex to where the
                               attraction alone would take it (keeps each solve well
                               posed with fewer than two handles and after tearing)
    handles : str              "uniform": every vertex is a soft handle of the same weight,
                               aimed where the field and attraction take it (the ARAP
                               systems are factorised once per mesh topology); "exact":
                               only vertices in a field are handles, the others follow
                               their ARAP position (factorised once per topology and
                               handle set, cached, so refactorised whenever a vertex
                               enters or leaves a field)
    handle_weight : float      weight of the handle constraints (Igarashi's soft handles)
    tear_ratio : float         an edge longer than this × its rest length is torn
    relink_ratio : float       a torn edge shorter than this × its rest length is relinked
    tear_interval : float      seconds between tearing/relinking checks (each change of the
                               torn set may cost a factorisation; 0: every step)
    occupy_distance : float    [L] an agent within L of its vertex occupies it; beyond it
                               is dislocated (§3.2)
    attraction_radius : float  [R(a)] of eq. (4); None: the formation's largest vertex
                               distance, as the paper suggests
    reassign : bool            dislocated agents may take any free vertex (§3.2); False
                               keeps every agent on its own vertex (cars keep their pair)
    repulsion_range : float    agents nearer than this (beyond contact) push each other
                               apart, the local repulsion F_r
    arrive_distance : float    a group whose centre is this close to its goal's centre
                               (or inside a goal region) is in its target area
    recovered_error : float    a group in its target area has recovered when its mean
                               relative edge-length error is below this, no agent is
                               dislocated, no edge is torn and every vertex is within L
                               of its place in the rest shape on the goal
    mesh_acceleration : float  [a_m] m/s²: comfortable motion (ours, see
                               crowdmotion.formation.comfort): a vertex's velocity changes
                               by at most this much per second, and in the target area a
                               vertex approaches its place no faster than it can stop in;
                               0: off (the paper's mesh, placed anew every step). A
                               ``cars`` formation keeps its own kinematics
    vertex_gap : float         metres: vertices nearer each other than two agents' radii
                               and this are pushed apart after every deformation (walkers,
                               not cars), so that agents on a compressed mesh are not
                               pressed together and stopped by the safety pass; 0: off
    """

    error_prefix = "formation"

    time_step: Annotated[float, Field(gt=0, le=MAX_TIME_STEP_S, allow_inf_nan=False)] = 0.1
    max_steps: Annotated[int, Field(gt=0, le=1_000_000)] = 3000
    fps: Fps | None = 24.0
    field_range: PosFloat = 2.0
    field_cell: PosFloat = 0.25
    repulsion: NonNeg = 2.0
    arap: Literal["two_step", "average"] = "two_step"
    shape_gain: PosFloat = 3.0
    anchor_weight: Annotated[float, Field(gt=0, le=10.0, allow_inf_nan=False)] = 0.02
    handles: Literal["uniform", "exact"] = "uniform"
    handle_weight: Annotated[float, Field(gt=0, le=1e8, allow_inf_nan=False)] = 10.0
    tear_ratio: Annotated[float, Field(gt=1.0, allow_inf_nan=False)] = 2.5
    relink_ratio: Annotated[float, Field(gt=1.0, allow_inf_nan=False)] = 1.5
    tear_interval: NonNeg = 0.5
    occupy_distance: PosFloat = 0.5
    attraction_radius: PosFloat | None = None
    reassign: bool = True
    repulsion_range: NonNeg = 0.3
    arrive_distance: PosFloat = 1.0
    recovered_error: PosFloat = 0.01
    mesh_acceleration: NonNeg = 0.8
    vertex_gap: NonNeg = 0.05

    @model_validator(mode="after")
    def _ranges(self):
        if self.relink_ratio > self.tear_ratio:
            raise ValueError(f"relink_ratio {self.relink_ratio} must not exceed tear_ratio {self.tear_ratio}")
        return self


class FormationAttributes(_Model):
    """What a group's ``attributes`` table may hold with the formation method.

    reassign : bool        as [formation] reassign, for this group (cars keep their pair)
    heading_deg : float    the direction the template faces at the start, degrees
                           counter-clockwise from +x (default: towards the goal)
    """

    reassign: bool | None = None
    heading_deg: Annotated[float, Field(ge=-360_000, le=360_000, allow_inf_nan=False)] | None = None


def make_params(params: FormationParams | dict | None = None, **overrides) -> FormationParams:
    """FormationParams from an instance, a dict or keywords (pydantic validates)."""
    base = {} if params is None else (params.model_dump() if isinstance(params, FormationParams) else dict(params))
    return FormationParams(**{**base, **overrides})
