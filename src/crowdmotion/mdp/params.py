"""Parameters of the MDP method: one pydantic model, used as the scenario's ``[mdp]``
block and by the Python API alike, so both validate the same way."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AliasChoices, BaseModel, ConfigDict, Field, field_validator

from crowdmotion._validation import MethodParams, Positive

PosFloat = Positive
STAGES = ("goto", "wait", "choose", "leave")  # the route stages an MDP group follows (validate reads it too)


class MDPParams(MethodParams):
    """Parameters of an MDP run (paper 000, Liu & Du 2019).

    cell_size : float | None   grid cell edge in metres; None = just over √2 × the largest
                               agent diameter (the paper's rule, §1.2)
    solver : str               "fast" (exact), or a paper reference solver "vi", "hvi",
                               "ivi", "dijkstra"
    theta : float              [θ] Algorithm 1's stopping threshold (paper: 1.0)
    tau : float                [τ] the Boltzmann temperature of eq. (4) (paper: 1)
    max_steps : int            [maxLength] of Algorithm 3
    forbid_crossing : bool     reject moves that pass closer than two radii mid-step
    corner_cutting : bool      False (default for scenes) = diagonal moves only past free
                               cells, so a body never clips an obstacle's corner; True =
                               the paper's rule
    remove_on_arrival : bool   agents that reach a goal cell leave the scene so others can
                               take the goal cells (the same option as rvo's; the old
                               name ``despawn`` is still read)
    stop_when_done : bool      end the run early once every agent has arrived (or is stuck)
    replan_every : int         with moving obstacles, re-solve the values every this many steps
                               (the cells they cover until then blocked)
    lookahead : int            ... and avoid the cells they cover this many steps after that
                               (nobody steps in; one standing there walks out)
    speed_limited_steps : bool  a step lasts long enough that the longest move made (√2
                               cells in 2D, √3 in 3D; planned for, with moving obstacles)
                               stays within every group's max_speed; false: the paper's
                               cell / pref_speed, whose diagonals run √2 (√3) × pref_speed
    smoothing : str | None     "relaxed" (default): the paths relaxed at ``fps`` (smoothed
                               over ``smoothing_window`` and kept apart, see
                               ``crowdmotion.path_relaxation``); None or "none" (cell
                               centres, one frame per step), "linear" or "catmull-rom"
                               resampling to ``fps``; audited in continuous time either way
    smoothing_window : float   seconds the "relaxed" paths are averaged over
    fps : float                frame rate of the smoothed output
    """

    error_prefix = "mdp"

    model_config = ConfigDict(extra="forbid", frozen=True)

    cell_size: PosFloat | None = None
    solver: Literal["fast", "vi", "hvi", "ivi", "dijkstra"] = "fast"
    theta: PosFloat = 1.0
    tau: PosFloat = 1.0
    max_steps: Annotated[int, Field(gt=0, le=1_000_000)] = 400
    forbid_crossing: bool = True
    corner_cutting: bool = False
    remove_on_arrival: bool = Field(False, validation_alias=AliasChoices("remove_on_arrival", "despawn"))
    stop_when_done: bool = True
    replan_every: Annotated[int, Field(gt=0)] = 4
    lookahead: Annotated[int, Field(ge=0)] = 4
    speed_limited_steps: bool = True
    smoothing: Literal["relaxed", "linear", "catmull-rom", "none"] | None = "relaxed"
    smoothing_window: Annotated[float, Field(gt=0, le=60.0, allow_inf_nan=False)] = 1.0
    fps: Annotated[float, Field(gt=0, le=1000.0, allow_inf_nan=False)] = 24.0

    @field_validator("smoothing")
    @classmethod
    def _none(cls, v):
        """``"none"``: a scenario file's way to say None (TOML has no null)."""
        return None if v == "none" else v


Params = MDPParams
