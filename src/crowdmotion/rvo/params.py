"""Parameters of the RVO method: one pydantic model, used as the scenario's ``[rvo]``
block and by the Python API alike, so both validate the same way."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from crowdmotion._validation import MethodParams, NonNegative, Positive
from crowdmotion.stage_kinds import KINDS

PosFloat = Positive
STAGES = KINDS  # the route stages an RVO agent follows: every one (validate reads it)
MAX_TIME_STEP_S = 10.0  # seconds: a longer step walks through walls between two looks
# seconds: above this step a crowd arrives late, then stalls (rvo.Simulator warns): the
# largest step at which 40 walkers crossing past a block in a 30 x 20 m room (two groups
# of 20 bound opposite ways) still arrive as at 0.25 s. Everyone in by 32-35 s at 0.25 s,
# 32-40 s at 0.5 s, 33-37 s at 0.6 s, 37-44 s at 0.7 s (seeds 0-4), 48-52 s at 1 s; at
# 2 s 6-14 of the 40 are still out after 60 s, at 5 s 26-31 (seeds 0-2). A door slows
# sooner: 40 through a 1.2 m door, the last out at 43-46 s at 0.25 s, 51-55 s at 0.5 s,
# 53-60 s at 0.6 s (seeds 0-2)
STALL_TIME_STEP_S = 0.6
# the per-agent parameters a group may set for itself (attributes) share these bounds
MAX_NEIGHBORS = 10_000
MAX_SAMPLES = 10_000
MaxNeighbors = Annotated[int, Field(ge=0, le=MAX_NEIGHBORS)]
NeighborDist = PosFloat
Samples = Annotated[int, Field(gt=0, le=MAX_SAMPLES)]
Safety = NonNegative


class RVOParams(MethodParams):
    """Parameters of the RVO method (paper symbols in brackets).

    time_step : float        simulation step Δt, seconds (above 0.6 s a warning: crowds
                             arrive late, then stall)
    max_steps : int          stop after this many steps even if agents are still walking
    max_neighbors : int      [M] nearest neighbours considered (groups without a personality)
    neighbor_dist : float    [D] metres within which neighbours count (groups without a personality)
    samples : int            [N_sample] random candidate velocities per agent and step (groups
                             without a personality)
    safety : float           [w] weight of 1/tc in the penalty, eq. (3) (groups without a
                             personality)
    dominant : "abs"|"max"   f(ψ): largest |ψk| (default) or the paper's literal max ψk
    guidance : str           "auto", "direct" or "field" (exact MDP distance field)
    field_cell : float|None  guidance grid cell, metres (default: agent radius)
    remove_on_arrival : bool  agents leave once within arrival_radius of their goal (once
                             inside it, for a goal region they arrive anywhere in)
    arrival_radius : float   metres
    goal_assignment : str    how region goals become points: "sample" (uniform in the goal
                             region, each where the agent's body fits), "shift" (start +
                             goal centre − spawn centre, clamped into the region: everyone
                             walks straight across) or
                             "nearest" (no point: each agent heads for the region's
                             nearest point, round walls along the guidance field, and
                             arrives anywhere in it: evacuees take the nearest exit)
    spawn_gap : float        extra clearance, metres, between agents sampled in a region
    keep_right_deg : float   degrees an agent turns v_pref right for an oncoming agent
                             ahead; 0 = off, and then the counterflow field reads the
                             oncoming flux at the move, not to its right; rvo.deadlock,
                             rvo.congestion, documented additions
    patience : float         seconds two agents may hold each other up before the one
                             of lower priority yields (rvo.deadlock)
    congestion : float       field guidance cost per metre 1 + congestion × density
                             (agents/m²), so crowds use a corridor's width (0 = no
                             density cost; with counterflow = 0 too, exact distances
                             only); rvo.congestion, a documented addition
    counterflow : float      extra field cost per metre walked against the crowd's flux,
                             × the flux (persons/m/s), so opposing streams form lanes
                             (0 = density alone); rvo.congestion, a documented addition
    replan_s : float         seconds between re-solves of the congestion-aware field
    density_slowing : bool   cap v_pref at Weidmann's speed for the density sensed ahead,
                             so crowds slow with density (rvo.density, a documented addition)
    follow : float           anticipated following in [0, 1]: a neighbour ahead bound our way
                             is expected to walk on towards its v_pref (0 = eq. (3)'s
                             reciprocal rule for every neighbour)
    lane_choice : bool       turn v_pref towards the side with the least oncoming traffic
                             ahead, so opposing streams form lanes (rvo.lanes)
    comfort_accel : float    m/s² of velocity change a walker makes at ease each second;
                             changes beyond it cost extra in the choice, so characters do
                             not twitch (0 = eq. (3)'s free choice; walkers only)
    squeeze_past : bool      a walker meeting an oncoming one in its way, bound the other
                             way, counts a wall only within 0.5 s, so it steps up to the
                             wall to let the other pass (rvo.deadlock; bodies up to
                             0.5 m radius only)
    pass_standing : bool     agents that have arrived and stay (waiting, queueing, gathered)
                             are passed as standing obstacles: a walker takes all the
                             avoidance and, while one stands in its way, counts what lies
                             beyond where it walks round it only once past it; one of
                             them steps aside for a walker held 2 s behind it (False =
                             eq. (3)'s reciprocal rule for them too)
    held_horizon : bool      a walker (radius up to 0.4 m) that has stood held up 3 s
                             counts a neighbour's collision only when met within 0.5 s,
                             so it takes a gap a straight ray beyond it would price above
                             standing (an arch in a door's mouth; rvo.deadlock)
    counterflow_safety : float  in (0, 1]: the share of w a walker keeps while it walks into
                             people bound the other way or across its way, so it passes
                             them as close as people do in counterflow and crossing
                             streams (rvo.density; walkers only; 1 = w)
    smoothing : str          "relaxed" (default): the run's steps relaxed for the characters
                             that play them (smoothed over ``smoothing_window`` and kept
                             apart, ``crowdmotion.path_relaxation.relaxed_steps``), audited
                             in continuous time; "none" (or None): the steps as simulated
    smoothing_window : float  seconds the "relaxed" steps are averaged over (an odd number
                             of steps, at least three); a longer window moves the paths
                             farther from the simulated ones, so more steps fail the
                             audit and keep their own move (80 walkers through a 0.9 m
                             door: 3 s played rougher than the default 1 s)
    """

    error_prefix = "rvo"

    model_config = ConfigDict(extra="forbid", frozen=True)

    time_step: Annotated[float, Field(gt=0, le=MAX_TIME_STEP_S, allow_inf_nan=False)] = 0.25
    max_steps: Annotated[int, Field(gt=0, le=1_000_000)] = 2000
    max_neighbors: MaxNeighbors = 10
    neighbor_dist: NeighborDist = 10.0
    samples: Samples = 50
    safety: Safety = 5.0
    dominant: Literal["abs", "max"] = "abs"
    guidance: Literal["auto", "direct", "field"] = "auto"
    field_cell: PosFloat | None = None
    remove_on_arrival: bool = True
    arrival_radius: PosFloat = 0.5
    goal_assignment: Literal["sample", "shift", "nearest"] = "sample"
    spawn_gap: NonNegative = 0.05
    keep_right_deg: Annotated[float, Field(ge=0, lt=90, allow_inf_nan=False)] = 15.0
    patience: PosFloat = 2.0
    congestion: NonNegative = 1.0
    counterflow: NonNegative = 20.0
    replan_s: PosFloat = 2.0
    density_slowing: bool = True
    follow: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.5
    lane_choice: bool = True
    comfort_accel: Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)] = 1.0
    squeeze_past: bool = True
    pass_standing: bool = True
    held_horizon: bool = True
    counterflow_safety: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.15
    smoothing: Literal["relaxed", "none"] = "relaxed"
    smoothing_window: Annotated[float, Field(gt=0, le=60.0, allow_inf_nan=False)] = 1.0

    @field_validator("smoothing", mode="before")
    @classmethod
    def _none(cls, v):
        """None (the Python API's way, as MDP's smoothing takes it) means ``"none"``."""
        return "none" if v is None else v


class RVOAttributes(BaseModel):
    """What a group's ``attributes`` table may hold with the RVO method: its own values of
    four of [rvo]'s parameters (bounded as there; not beside a personality, which sets
    them), and differing walking speeds.

    pref_speed_range : list  [low, high]: each agent's preferred speed drawn uniformly
                             from it, m/s, within max_speed (RiMEA test 7)
    max_neighbors : int      [M] as [rvo] max_neighbors, for this group (without a personality)
    neighbor_dist : float    [D] as [rvo] neighbor_dist, metres (without a personality)
    samples : int            [N_sample] as [rvo] samples (without a personality)
    safety : float           [w] as [rvo] safety (without a personality)
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    pref_speed_range: Annotated[list[PosFloat], Field(min_length=2, max_length=2)] | None = None
    max_neighbors: MaxNeighbors | None = None
    neighbor_dist: NeighborDist | None = None
    samples: Samples | None = None
    safety: Safety | None = None

    @model_validator(mode="after")
    def _range(self):
        r = self.pref_speed_range
        if r is not None and r[0] > r[1]:
            raise ValueError(f"pref_speed_range: low {r[0]:g} exceeds high {r[1]:g}")
        return self


Params = RVOParams
