"""The interactive RVO simulator: add agents, step, read positions and velocities."""

from __future__ import annotations

import warnings

import numba
import numpy as np
from scipy.ndimage import minimum_filter
from scipy.spatial import cKDTree

from crowdmotion._rng import step_key
from crowdmotion._threads import ThreadedKernel
from crowdmotion._validation import id_range
from crowdmotion.facing import MAX_TURN_RATE, STANDING_FRACTION, turn_towards, wrap
from crowdmotion.geometry import finite_array, finite_number, require_finite_agents, row_norms
from crowdmotion.groups import Disc, Lattice, MovingTarget, Points, Rect
from crowdmotion.placement import GOAL_CLEARANCE_M, standing_points
from crowdmotion.rvo import _kernels as K
from crowdmotion.rvo import congestion as _congestion
from crowdmotion.rvo import deadlock as _deadlock
from crowdmotion.rvo.congestion import CongestionRouter
from crowdmotion.rvo.deadlock import (KEEP_RIGHT_LOOK_S, SQUEEZE_MAX_RADIUS_M, SQUEEZE_SIDE_M, SQUEEZE_WALL_S,
                                      Deadlock, contact_arrivals)
from crowdmotion.rvo.density import COUNTERFLOW_SAFETY, PERSON_MAX_RADIUS_M, DensitySlowing
from crowdmotion.rvo.lanes import LaneChoice
from crowdmotion.routing import DistanceFields, distance_fields
from crowdmotion.rvo.guidance import field_window, preferred_velocities
from crowdmotion._contact import grid_for
from crowdmotion.live_obstacles import LiveObstacles
from crowdmotion.obstacle_primitives import ObstacleSet
from crowdmotion.rvo.params import MAX_NEIGHBORS, MAX_SAMPLES, MAX_TIME_STEP_S, STALL_TIME_STEP_S
from crowdmotion.rvo.personality import PARAM_KEYS, params_for_vectors, sample_personalities
from crowdmotion.scene import Box, Scene

BRISK = 3.0  # an agent breaking a stand-off (yielding, detouring) changes velocity this much faster
FOLLOW_FULL_DENSITY = 2.0  # persons/m² sensed ahead from which following is anticipated in full
ESCAPE_HEADINGS = 32  # headings an agent in a moving obstacle's way tries after the safety pass
# used when neither a value nor a personality is given: the neutral set of Table 4's
# O pair (mid-way between O+ and O−), rounded
ENTRY_GAP_M = 0.05  # clearance an entering agent needs round its body
ENTRY_NEIGHBOURS = 8  # bodies nearest its place an entering agent is checked against
PACKED_CREEP_MPS = 0.1  # a walker packed round a goal point it shares with others edges towards it this slowly
# different goal points given in one call without a goal_region get a guidance field each,
# up to this many (a field is a grid of the scene; more are grouped by place into this many)
OWN_FIELDS_MAX = 16
# guidance fields nobody walks to any more are kept (a goal given again reuses its field at
# once) up to this much memory, at least UNUSED_FIELDS_MIN of them; beyond that the longest
# unused give their places to new goals' fields, so that a game sending its crowd to ever
# new goals holds fields for the goals in use, not for every goal ever given
UNUSED_FIELDS_MB = 64.0
UNUSED_FIELDS_MIN = 8
# the congestion-aware fields of a replan period are re-solved within this many seconds
# of its first step, the searches cut into slices spread over the steps in it ...
REPLAN_SPREAD_S = 0.25
# ... or over more steps, up to the period, where the fields hold more cells than this a
# step (a few milliseconds of searching)
REPLAN_CELLS_PER_STEP = 50_000
DEFAULTS = {"max_neighbors": 10, "neighbor_dist": 10.0, "samples": 50, "safety": 5.0}


def _stacked(rows: np.ndarray, more: np.ndarray) -> np.ndarray:
    """``rows`` with ``more`` after them (along the first axis), written into the spare
    rows of the buffer ``rows`` are the first rows of, when it has room; else into a new
    buffer with half as much room again as they need (at least 16 rows more). A game that
    adds a field at every frame pays for the new field, not for a copy of all those held
    (120 fields of a 50 × 40 m plaza: 4.5 ms a frame), but for a few copies as they grow."""
    n, k = len(rows), len(more)
    buf = rows.base
    if not (isinstance(buf, np.ndarray) and buf.ndim == rows.ndim and buf.shape[1:] == rows.shape[1:]
            and n + k <= len(buf) and buf.dtype == rows.dtype and rows.flags.c_contiguous
            and rows.__array_interface__["data"][0] == buf.__array_interface__["data"][0]):
        buf = np.empty((n + k + max(16, (n + k) // 2),) + rows.shape[1:], dtype=rows.dtype)
        buf[:n] = rows
    buf[n:n + k] = more
    return buf[:n + k]


def _per_agent(value, n: int, name: str, integer: bool = False, minimum: float = 0.0,
               strict: bool = True, maximum: float = np.inf) -> np.ndarray:
    """Broadcast a scalar or (n,) array, checking it is finite, above ``minimum`` and at
    most ``maximum``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or one number per agent ({n}), got {value!r}") from None
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != n):
        raise ValueError(f"{name} must be a number or one number per agent ({n}), got shape {arr.shape}")
    arr = np.broadcast_to(arr, (n,)).copy()
    bad = ~np.isfinite(arr) | ((arr <= minimum) if strict else (arr < minimum)) | (arr > maximum)
    if integer:
        bad |= arr != np.round(arr)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        need = ("finite and " if not np.isfinite(arr[i]) else "") + f"{'>' if strict else '>='} {minimum:g}" \
            + (" whole" if integer else "") \
            + (f" and at most {maximum:g}" if maximum < np.inf else "")
        raise ValueError(f"{name} must be {need}, got {float(arr[i])!r} for the {_ordinal(i)} of the {n} agents given")
    return arr.astype(np.int64) if integer else arr


def _is_goal_region(region) -> bool:
    """Whether ``region`` is one a guidance field leads to: a Rect (not a spawn's
    Lattice), Disc or Points."""
    return isinstance(region, (Rect, Disc, Points)) and not isinstance(region, Lattice)


#: a goal point farther than this from its goal_region is told of
GOAL_OUTSIDE_REGION_M = 0.5


def _warn_goals_outside(goal: np.ndarray, region, what: str) -> None:
    """Warn when goal points lie away from the goal_region given with them: the guidance
    field leads to the region, and from there the agents walk straight for their points."""
    if isinstance(region, MovingTarget):
        return
    off = row_norms(goal - region.nearest(goal)[:, :2]) > GOAL_OUTSIDE_REGION_M
    if off.any():
        k = int(np.flatnonzero(off)[0])
        warnings.warn(f"{what}: {int(off.sum())} of the {len(goal)} goal points lie outside their goal_region "
                      f"{region!r} (the first, {np.round(goal[k], 3).tolist()}): the guidance field leads to the "
                      f"region, and from there the agents walk straight for their points", UserWarning, stacklevel=3)


def _xy_each(value, n: int, name: str) -> np.ndarray:
    """``value`` as (n, 2): one (2,) pair for all, or one pair each; ValueError naming
    ``name`` for NaN, inf or another shape."""
    xy = finite_array(value, name)
    xy = np.tile(xy, (n, 1)) if xy.shape == (2,) else xy
    if xy.shape != (n, 2):
        raise ValueError(f"{name} must be (2,) or ({n}, 2), got shape {xy.shape}")
    return xy


# an agent that leaves on entering its goal region (an exit, a safe area) walks for the
# region's nearest point this far inside it (less in a thinner region, and moved to where
# its body fits), so that it walks in: heading for the region's edge, it left up to
# ``arrival_radius`` short of it (short of the door it was to pass, for an exit area just
# behind one). It leaves once its centre is in the region, or within AIM_REACHED_M of that
# point (a strip along a wall too thin to hold its centre)
LEAVE_INSET_M = 0.25
AIM_REACHED_M = 0.1


def _inset_box(region) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of ``region`` (a Rect or Disc) shrunk by ``LEAVE_INSET_M`` (to its
    middle, where it is thinner than twice that): the Rect itself, or the Disc's box."""
    if isinstance(region, Rect):
        m = np.minimum(LEAVE_INSET_M, (region.upper - region.lower) / 2)
        return region.lower + m, region.upper - m
    inner = max(region.radius - LEAVE_INSET_M, 0.0)
    return region.center - inner, region.center + inner


def _inset_nearest(region, points: np.ndarray) -> np.ndarray:
    """The nearest points of ``region`` (a Rect or Disc) shrunk by ``LEAVE_INSET_M``."""
    p = np.asarray(points, dtype=float)
    lo, hi = _inset_box(region)
    if isinstance(region, Rect):
        return np.clip(p, lo, hi)
    off = p - region.center
    d = np.linalg.norm(off, axis=-1, keepdims=True)
    return region.center + off * np.minimum(1.0, 0.5 * float(hi[0] - lo[0]) / np.maximum(d, 1e-300))


class Simulator(LiveObstacles):
    """Sampling RVO (van den Berg, Lin & Manocha 2008) with per-agent parameters.

    ``sim = Simulator(scene, time_step=0.25)``, then ``sim.add_agents(...)`` and
    ``sim.step()``. Positions and velocities are (N, 2) arrays over every agent ever
    added; ``sim.active`` says who is still walking. Between steps, ``set_goals`` sends
    agents elsewhere, ``remove_agents`` takes them out, ``drive`` moves agents at the
    caller's own velocities (a game's player, a robot) and ``place`` puts agents
    elsewhere (the live API; read the arrays, do not write them). The steps are as
    simulated: in a dense crowd they stop and go (acceleration p95 above 2 m/s² at a busy
    door), which a character bound to them shows; ``rvo.simulate`` and the scenario
    runner return runs relaxed for characters (``RVOParams.smoothing``), which needs the
    frames after each one, so a game that steps live smooths the drawn position on its
    side, and :class:`crowdmotion.rvo.recorder.Recorder` relaxes a recorded session
    afterwards. :func:`warm_up` readies the kernels before a game's first frame.
    ``sim.dt`` is the time step. ``sim.facing`` is each agent's heading for a character's
    root, turned at a bounded rate each step (the velocities snap round in a crowd).

    Parameters
    ----------
    scene : Scene
        2D scene; its obstacles (static or keyframed) are avoided.
    time_step : float
        Seconds per step (the paper's simulation step), at most ``MAX_TIME_STEP_S`` (10 s,
        as ``[rvo] time_step``); above ``STALL_TIME_STEP_S`` (0.6 s) a UserWarning:
        crowds arrive late, then stall.
    guidance : "auto", "direct" or "field"
        How v_pref is found: straight at the goal, or along an exact MDP distance field
        whenever the straight line is blocked ("auto": the field if the scene has static
        obstacles).
    remove_on_arrival : bool
        Agents within ``arrival_radius`` of their goal leave the simulation (default);
        otherwise they stay there as obstacles to the others.
    arrival_radius : float
        Metres from the goal point at which an agent counts as arrived.
    field_cell : float, optional
        Cell edge of the guidance field (default: the largest agent radius, coarsened
        for very large scenes).
    dominant : "abs" or "max"
        How a personality's dominant trait is chosen (see ``personality.dominant_trait``).
    rng : numpy.random.Generator, optional
        Source of the candidate samples (default ``default_rng(0)``).
    keep_right_deg : float
        Degrees by which an agent turns its v_pref to the right when an oncoming agent is
        ahead; 0 = off, and the counterflow field then reads the oncoming flux at each
        move rather than to its right; see :mod:`crowdmotion.rvo.deadlock` and
        :mod:`crowdmotion.rvo.congestion`.
    patience : float
        Seconds two agents may hold each other up before the one of lower priority
        yields; see :mod:`crowdmotion.rvo.deadlock`.
    congestion : float
        With field guidance, walking through a cell costs ``1 + congestion × density``
        (agents/m²) per metre, and the field is re-solved every ``replan_s`` seconds, so a
        crowd spreads over a corridor's width (:mod:`crowdmotion.rvo.congestion`); 0 = no
        density cost (with ``counterflow = 0`` too, the exact distance field only).
    counterflow : float
        With the congestion-aware field, walking a metre against the crowd's flux J
        (persons per metre per second, the smoothed sum of the agents' velocities per m²)
        costs ``counterflow × J`` metres more, so each stream's field leads along the side
        its own stream walks on and opposing streams form lanes
        (:mod:`crowdmotion.rvo.congestion`); 0 = density alone.
    replan_s : float
        Seconds between two re-solves of the congestion-aware fields, from the crowd at
        the period's first step; with several goal regions and short steps (a game's
        frames) the Dijkstras are spread over the first 0.25 s and the new fields taken
        together, so that no frame pays for all of them.
    density_slowing : bool
        Cap each agent's preferred speed at what Weidmann's fundamental diagram allows at
        the density it senses ahead (:mod:`crowdmotion.rvo.density`), so crowds slow with
        density as real ones do; False = eq. (3) alone.
    follow : float
        Anticipated following in a crowd, in [0, 1]: a neighbour straight ahead bound the
        same way (v_pref within 25° of ours) is expected to walk on, its velocity taken
        ``follow`` (scaled by the density sensed ahead, full from 2 persons/m²) of the
        way from its current one to its v_pref, and to make no room for us (the plain
        velocity obstacle instead of the reciprocal one); 0 = eq. (3)'s reciprocal rule
        for everyone. See :func:`crowdmotion.rvo._kernels.choose_velocities`.
    lane_choice : bool
        Turn v_pref towards the side with the least oncoming traffic ahead, so opposing
        streams form lanes (:mod:`crowdmotion.rvo.lanes`); False = v_pref as guidance gives it.
    comfort_accel : float
        Metres per second² of velocity change a walker makes at ease: a change beyond
        ``comfort_accel × time_step`` in one step costs ``COMFORT_WEIGHT`` per m/s beyond
        it in eq. (3)'s penalty (times 0.25 s / ``time_step`` at shorter steps: priced by
        the acceleration, as at the default step), and near its goal a walker slows enough
        to turn in at this acceleration instead of circling the goal (``_turned_in``);
        walkers (radius up to 0.4 m) only. 0 = eq. (3)'s free choice. See
        :func:`crowdmotion.rvo._kernels.choose_velocities`.
    squeeze_past : bool
        A walker meeting an oncoming one in its way, bound the other way, counts a wall
        only when it would meet it within ``SQUEEZE_WALL_S`` (0.5 s), so it steps up to
        the wall to let the other pass instead of standing (:mod:`crowdmotion.rvo.deadlock`,
        rule 1); people (radius up to ``SQUEEZE_MAX_RADIUS_M``, 0.5 m: SteerSuite's bodies
        too) only. False = every wall counts as eq. (3) has it.
    counterflow_safety : float
        In (0, 1]: the share of w (eq. (3)) a walker keeps while it walks into people bound
        the other way or across its way (sensed ahead, :mod:`crowdmotion.rvo.density`), so
        that it passes them at the close range real walkers accept in counterflow and in
        crossing streams instead of backing off; walkers (radius up to 0.4 m) only. 1 = w
        throughout.
    pass_standing : bool
        Agents that have arrived and stay (waiting, in a queue, gathered round their goal)
        are passed as standing obstacles: a walker takes all the avoidance of one (eq. (3)'s
        ray along v′ against its own velocity, not the reciprocal 2v′ − v_i − v_j), and
        while one stands in its way it counts a wall or another standing one only up to
        ``PASS_BEYOND_M`` past it, where it turns (:func:`crowdmotion.rvo._kernels.choose_velocities`);
        one standing ignores a walker that stops short of it (its goal nearer), and steps
        aside for one that has stood 2 s behind it with its goal beyond. False =
        eq. (3)'s reciprocal rule for them too.
    held_horizon : bool
        A walker (radius up to 0.4 m) that has stood held up ``_kernels.HELD_LONG_S``
        seconds counts a neighbour's collision only when met within
        ``_kernels.HELD_HORIZON_S``: it takes a gap between two pressed on a door's wall
        faces that a straight ray meeting the body beyond would price above standing.
        False: eq. (3)'s collisions at any time.
    """

    def __init__(self, scene: Scene, time_step: float = 0.25, guidance: str = "auto",
                 remove_on_arrival: bool = True, arrival_radius: float = 0.5,
                 field_cell: float | None = None, dominant: str = "abs",
                 rng: np.random.Generator | None = None, keep_right_deg: float = 15.0,
                 patience: float = 2.0, congestion: float = 1.0, replan_s: float = 2.0,
                 density_slowing: bool = True, follow: float = 0.5, lane_choice: bool = True,
                 comfort_accel: float = 1.0, counterflow: float = 20.0, squeeze_past: bool = True,
                 counterflow_safety: float = COUNTERFLOW_SAFETY, pass_standing: bool = True,
                 held_horizon: bool = True):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a crowdmotion.Scene, got {scene!r}")
        if not (finite_number(time_step) and 0 < time_step <= MAX_TIME_STEP_S):
            raise ValueError(f"time_step must be a positive number of seconds, at most {MAX_TIME_STEP_S:g}, "
                             f"got {time_step!r}")
        if time_step > STALL_TIME_STEP_S:
            warnings.warn(f"time_step {time_step!r} s is above {STALL_TIME_STEP_S:g} s: agents look once a step and "
                          "walk up to max_speed x time_step before the next look, so crowds arrive late, then stall "
                          "(40 walkers crossing a room: all in by 32-35 s at 0.25 s, 48-52 s at 1 s; 6-14 of them "
                          "still out after 60 s at 2 s). A game with a variable frame time steps a fixed short step "
                          "as often as its frames need (docs/rvo.md)", UserWarning, stacklevel=2)
        if guidance not in ("auto", "direct", "field"):
            raise ValueError(f"guidance must be 'auto', 'direct' or 'field', got {guidance!r}")
        if not (finite_number(arrival_radius) and arrival_radius > 0):
            raise ValueError(f"arrival_radius must be a positive number of metres, got {arrival_radius!r}")
        if dominant not in ("abs", "max"):
            raise ValueError(f"dominant must be 'abs' or 'max', got {dominant!r}")
        if not (finite_number(keep_right_deg) and 0 <= keep_right_deg < 90):
            raise ValueError(f"keep_right_deg must be in [0, 90) degrees, got {keep_right_deg!r}")
        if not (finite_number(patience) and patience > 0):
            raise ValueError(f"patience must be a positive number of seconds, got {patience!r}")
        if not (finite_number(congestion) and congestion >= 0):
            raise ValueError(f"congestion must be a number >= 0, got {congestion!r}")
        if not (finite_number(counterflow) and counterflow >= 0):
            raise ValueError(f"counterflow must be a number >= 0, got {counterflow!r}")
        if not (finite_number(replan_s) and replan_s > 0):
            raise ValueError(f"replan_s must be a positive number of seconds, got {replan_s!r}")
        self.congestion = float(congestion)
        self.counterflow = float(counterflow)
        self.replan_steps = max(1, int(round(replan_s / time_step)))
        self.scene = scene  # with every obstacle ever in it, each with the time it stood (for the audit)
        self.journeys = None  # the route state machine, once a route is set (set_route, or a scenario's)
        self._now = scene   # the obstacles standing now
        self._inset_clear: dict = {}  # _inset_clearance of a region, with the static obstacles it was found among
        self._scene_owned = False
        self.dt = float(time_step)
        self.guidance = guidance
        self.remove_on_arrival = bool(remove_on_arrival)
        self.arrival_radius = float(arrival_radius)
        self.field_cell = field_cell
        self.dominant = dominant
        self.rng = np.random.default_rng(0) if rng is None else rng
        self.obstacles = ObstacleSet(scene)
        self.steps = 0
        # (steps at the time, ids) of each place(): a Recorder marks those moves as jumps,
        # which the audit and the relaxation for characters do not take as walked
        self.placements: list[tuple[int, np.ndarray]] = []
        self._unchecked = np.zeros(0, dtype=np.int64)  # agents added or sent on whose goal the field has not judged
        n0 = (0, 2)
        self.positions = np.zeros(n0)
        self.velocities = np.zeros(n0)
        self._facing = np.zeros(0)  # yaw, radians; NaN: added on its goal and not moved yet
        self.goals = np.zeros(n0)
        self.active = np.zeros(0, dtype=bool)
        self.arrival_time = np.zeros(0)
        self.packed = np.zeros(0, dtype=bool)  # arrived at a goal point it shares with others, staying
        self.enter_at = np.zeros(0)     # when each agent is due to enter, seconds
        self.anywhere = np.zeros(0, dtype=bool)  # arrives anywhere in its goal region (its goal: the nearest point)
        self.leaves = np.zeros(0, dtype=bool)    # leaves the simulation on arrival (else stays there)
        self.entry_time = np.zeros(0)   # when it entered (NaN while it waits off-scene)
        self.entrance = np.zeros(0, dtype=np.int64)  # the entrance it enters at (-1: none named)
        self.group = np.zeros(0, dtype=np.int64)     # the add_agents call that added each agent
        self.field_of = np.zeros(0, dtype=np.int64)  # each agent's goal region (its guidance field)
        self.driven = np.zeros(0, dtype=bool)  # moved by the caller (drive), not by the crowd's choice
        self.drive_velocity = np.zeros(n0)
        self.params = {k: np.zeros(0, dtype=np.int64 if k in ("max_neighbors", "samples") else float)
                       for k in PARAM_KEYS}
        for k in ("radius", "max_speed", "pref_speed"):
            self.params[k] = np.zeros(0)
        self.personality = np.zeros((0, 5))
        self._targets: list[tuple[MovingTarget, np.ndarray]] = []
        self._goal_regions: list = []
        self._region_keys: list = []  # one per goal region, so a region given twice has one field
        self._region_ids: dict[int, int] = {}  # id(region object) -> its index: no repr per call
        self._grouped: set[int] = set()  # fields shared by a group of nearby goal points
        self._no_own_field: set[tuple] = set()  # (agent, goal x, goal y) whose own field cannot be solved
        self._pinned: set[int] = set()  # fields of add_goal_regions: kept for the run, used or not
        self._asked_at: list[int] = []  # per field: the step it was last asked for (longest unused reused first)
        self._regions_added = 0  # goal regions added so far (in new places or in reused ones)
        self._batches = 0
        self._fields: DistanceFields | None = None
        self._exact: np.ndarray | None = None  # the exact distances, while _fields holds the weighted ones
        self._router: CongestionRouter | None = None
        self._weights = None  # the router's cell and edge weights for this replan period
        self._replanning = None  # (fields re-solving this period, the crowd they answer, cells a step settles,
        # the searches begun, the fields solved)
        self._partial: set[int] = set()  # congestion-aware fields solved only near their agents
        self._partial_weights = None  # the graph weights they were solved with
        self._solved_round = None  # per field and cell: the window round it all solved (True off those fields)
        self._weighted: set[int] = set()  # the fields whose rows of _fields.dist hold weighted distances
        self._solved = np.zeros(0, dtype=bool)  # per goal region: its field solved for the obstacles now
        self._fields_stale = True
        self.deadlock = Deadlock(np.deg2rad(keep_right_deg), float(patience))
        for name, flag in (("density_slowing", density_slowing), ("lane_choice", lane_choice),
                           ("squeeze_past", squeeze_past), ("pass_standing", pass_standing),
                           ("held_horizon", held_horizon)):
            if not isinstance(flag, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, got {flag!r}")
        if not (isinstance(follow, (int, float)) and np.isfinite(follow) and 0 <= follow <= 1):
            raise ValueError(f"follow must be a number in [0, 1], got {follow!r}")
        self.follow = float(follow)
        if not (isinstance(comfort_accel, (int, float)) and np.isfinite(comfort_accel) and comfort_accel >= 0):
            raise ValueError(f"comfort_accel must be a number of m/s² >= 0, got {comfort_accel!r}")
        self.comfort_accel = float(comfort_accel)
        self.lane_choice = bool(lane_choice)
        self.squeeze_past = bool(squeeze_past)
        self.pass_standing = bool(pass_standing)
        self.held_horizon = bool(held_horizon)
        if not (isinstance(counterflow_safety, (int, float)) and np.isfinite(counterflow_safety)
                and 0 < counterflow_safety <= 1):
            raise ValueError(f"counterflow_safety must be a number in (0, 1], got {counterflow_safety!r}")
        self.counterflow_safety = float(counterflow_safety)
        self.lanes = LaneChoice(self.dt)
        # the density sensed ahead slows walkers, scales following and lane choice, and eases w
        # in counterflow and crossings
        self.density_slowing = DensitySlowing(scene, bool(density_slowing),
                                              sense=bool(density_slowing) or self.follow > 0 or self.lane_choice
                                              or self.counterflow_safety < 1)
        self.stats = {"safety_stops": 0, "forced_choices": 0, "agent_steps": 0, "yields": 0,
                      "contact_arrivals": 0, "escapes": 0}

    # ---- agents ------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Seconds simulated: ``steps`` × ``dt``, as the frames count them (no running sum
        that drifts from it)."""
        return self.steps * self.dt

    @property
    def n_agents(self) -> int:
        return len(self.positions)

    def add_agents(self, positions, goals, radius=0.25, max_speed=1.5, pref_speed=1.3,
                   neighbor_dist=None, max_neighbors=None, samples=None, safety=None,
                   personality=None, goal_region=None, enter_at=None, arrive_anywhere=False,
                   entrance=None) -> np.ndarray:
        """Add agents; every parameter is a scalar or one value per agent.

        Parameters
        ----------
        positions : (N, 2) start positions, metres; none (an empty wave) adds nobody and
            returns an empty id array (the goals are still checked).
        goals : (N, 2) goal points, (2,) or (1, 2) one for all, or a MovingTarget they all
            chase. A point closer to a wall or the scene's edge than its agent's radius (no
            body stands there) is moved the least way to where the body fits, with a
            warning (once the agents are known to fit: a call refused warns of nothing).
        radius, max_speed, pref_speed : body radius (m), v_max and |v_pref| (m/s).
        neighbor_dist : D, metres: neighbours farther away are ignored.
        max_neighbors : M: at most this many nearest neighbours are considered.
        samples : N_sample: random candidate velocities per step.
        safety : w in eq. (3): the weight of 1 / time-to-collision in the penalty.
        personality : a pole name ("O+"), an OCEAN 5-vector, (N, 5) vectors, or a
            distribution mapping; sets M, D, N_sample and w from Table 4 (then those four
            must not be given as well).
        goal_region : the group's goal region, used to build the guidance field (default:
            the goal points).
        arrive_anywhere : head for the nearest point of ``goal_region`` (a Rect or Disc;
            along the guidance field where walls are in the way) and arrive anywhere in
            it, instead of at the given goal points (an evacuee reaching safety, a
            walker entering a square). Agents that leave on arrival head for the
            nearest point ``LEAVE_INSET_M`` inside it and leave once their centre is in it.
        enter_at : when each agent is due to enter, seconds (default: now). Until then,
            and after it while someone stands on its start position, it waits off-scene
            (``waiting``): not drawn, not avoided, not stepped; it enters at the end of the
            first step after which its place is free (see :meth:`set_entry_points`).
        entrance : which entrance each agent enters at, an index ≥ 0 the caller gives
            meaning to (``entrance``; the scenario runner: into the group's
            ``enter.entrances``), or -1 (default) for none named.

        Returns
        -------
        (N,) int array of the new agents' ids (their rows in ``positions``).
        """
        pos = finite_array(positions, "positions")
        if pos.shape in ((0,), (0, 2)):
            # an empty wave (a spawner's np.flatnonzero(mask) that matched no one): nothing
            # added, as set_goals, drive, place and remove_agents take an empty selection
            self._goal_points(goals, 0)  # the goal is still checked: a NaN goal still raises
            if goal_region is not None:
                self._check_goal_region(goal_region)
            return np.zeros(0, dtype=np.int64)
        if pos.ndim != 2 or pos.shape[1] != 2:
            raise ValueError(f"positions must be an (N, 2) array, got shape {pos.shape}")
        n = len(pos)
        goal, target = self._goal_points(goals, n)
        if goal_region is not None:
            self._check_goal_region(goal_region)
        anywhere = bool(arrive_anywhere)
        if anywhere and not isinstance(goal_region, (Rect, Disc)):
            raise ValueError(f"arrive_anywhere needs a Rect or Disc goal_region, got {goal_region!r}")
        rad = _per_agent(radius, n, "radius")
        vmax = _per_agent(max_speed, n, "max_speed")
        vpref = _per_agent(pref_speed, n, "pref_speed")
        over = np.flatnonzero(vpref > vmax)
        if len(over):
            i = int(over[0])
            raise ValueError(f"pref_speed {vpref[i]} exceeds max_speed {vmax[i]} for the {_ordinal(i)} of the {n} "
                             "agents given")
        given = {"neighbor_dist": neighbor_dist, "max_neighbors": max_neighbors, "samples": samples,
                 "safety": safety}
        if personality is not None:
            clash = [k for k, v in given.items() if v is not None]
            if clash:
                raise ValueError(f"personality sets {clash}; give either a personality or those parameters")
            psi = sample_personalities(personality, n, self.rng)
            given = params_for_vectors(psi, self.dominant)
        else:
            psi = np.full((n, 5), np.nan)
            given = {k: DEFAULTS[k] if v is None else v for k, v in given.items()}
        per = {
            "neighbor_dist": _per_agent(given["neighbor_dist"], n, "neighbor_dist"),
            "max_neighbors": _per_agent(given["max_neighbors"], n, "max_neighbors", integer=True, strict=False,
                                        maximum=MAX_NEIGHBORS),
            "samples": _per_agent(given["samples"], n, "samples", integer=True, maximum=MAX_SAMPLES),
            "safety": _per_agent(given["safety"], n, "safety", strict=False),
            "radius": rad, "max_speed": vmax, "pref_speed": vpref,
        }
        due = np.full(n, self.time) if enter_at is None else _per_agent(enter_at, n, "enter_at", strict=False)
        door = np.full(n, -1, dtype=np.int64) if entrance is None else \
            _per_agent(entrance, n, "entrance", integer=True, strict=False, minimum=-1)
        later = np.full(n, enter_at is not None)  # given times: every one enters through _admit, when free
        self._check_placement(pos, rad, ~later)
        # the goals' warnings (moved, outside their region) once the agents are known to fit
        if goal_region is not None and target is None and not anywhere:
            _warn_goals_outside(goal, goal_region, "add_agents")
        if anywhere:
            goal = self._aims(goal_region, pos, np.full(n, self.remove_on_arrival), rad)
        if target is None and not anywhere:
            goal = self._standing_goals(goal, rad, goal_region)
        # fields already solved serve bodies no wider: only new goals' fields are solved
        # (a wider body needs every field again, with its clearance: rebuilt when next used)
        keep = self._fields is not None and not self._fields_stale and rad.max() <= self.params["radius"].max()
        fields = self._field_indices(goal, goal_region, solve=keep)  # may refuse the goals: before any change
        start = self.n_agents
        ids = np.arange(start, start + n)
        self.positions = np.concatenate([self.positions, pos])
        self.velocities = np.concatenate([self.velocities, np.zeros((n, 2))])
        self._facing = np.concatenate([self._facing, _heading(goal - pos)])
        self.goals = np.concatenate([self.goals, goal])
        self.active = np.concatenate([self.active, ~later])
        self.arrival_time = np.concatenate([self.arrival_time, np.full(n, np.nan)])
        self.packed = np.concatenate([self.packed, np.zeros(n, dtype=bool)])
        self.enter_at = np.concatenate([self.enter_at, due])
        self.anywhere = np.concatenate([self.anywhere, np.full(n, anywhere)])
        self.leaves = np.concatenate([self.leaves, np.full(n, self.remove_on_arrival)])
        self.entry_time = np.concatenate([self.entry_time, np.where(later, np.nan, self.time)])
        self.entrance = np.concatenate([self.entrance, door])
        self.personality = np.concatenate([self.personality, psi])
        for k, v in per.items():
            self.params[k] = np.concatenate([self.params[k], v])
        self.field_of = np.concatenate([self.field_of, fields])
        self.driven = np.concatenate([self.driven, np.zeros(n, dtype=bool)])
        self.drive_velocity = np.concatenate([self.drive_velocity, np.zeros((n, 2))])
        self.group = np.concatenate([self.group, np.full(n, self._batches)])
        self._batches += 1
        self.deadlock.grow(n)
        self.lanes.grow(n)
        self.density_slowing.grow(n)
        if target is not None:
            self._targets.append((target, ids))
        self._fields_stale |= not keep
        self._unchecked = np.concatenate([self._unchecked, ids])
        self._admit()
        return ids

    def set_goals(self, agents, goals, goal_region=None, arrive_anywhere: bool = False,
                  leave: bool | None = None) -> None:
        """Send agents to new goals from the next step on (the live API).

        Parameters
        ----------
        agents : ids (rows of ``positions``) of agents still in the simulation.
        goals : (2,) or (1, 2) one goal point for all of them, (K, 2) one each, or a MovingTarget
            they all chase (points no body stands on are moved, as in :meth:`add_agents`).
        goal_region : the region the goals lie in, for the guidance field (default: the
            goal points). A region given before, or the same points, reuses its field.
        arrive_anywhere : head for the region's nearest point and arrive anywhere in it
            (see :meth:`add_agents`).
        leave : whether they leave the simulation on arriving there (an exit) or stay
            (a place on the way); None: as ``remove_on_arrival`` says.

        The new goal's guidance field (with field guidance) is solved here, so a goal
        that cannot be used (inside a wall, off the grid) raises ValueError and every
        agent keeps its old goal. Agents that had arrived and stayed walk again; their
        stand-off state (yielding, detours) is cleared.
        """
        one_each = not isinstance(goals, MovingTarget) and np.ndim(goals) == 2 and len(goals) > 1
        # a goal for each: an id given twice would leave its goals unmatched
        ids = self._distinct_ids(agents, "set_goals") if one_each else self._agent_ids(agents, "set_goals")
        goal, target = self._goal_points(goals, len(ids))
        if goal_region is not None:
            self._check_goal_region(goal_region)
            if target is None and not arrive_anywhere:
                _warn_goals_outside(goal, goal_region, "set_goals")
        self._ensure_fields()
        if arrive_anywhere and not isinstance(goal_region, (Rect, Disc)):
            raise ValueError(f"arrive_anywhere needs a Rect or Disc goal_region, got {goal_region!r}")
        if not len(ids):
            # nobody named (a game's np.flatnonzero(mask) that matched no one): nothing to
            # change, as drive, place and remove_agents take it; the goal points' own field
            # below would refuse an empty set of points, naming neither the call nor the agents
            return
        if target is None and not arrive_anywhere:
            goal = self._standing_goals(goal, self.params["radius"][ids], goal_region)
        field = self._field_indices(goal, goal_region)
        self._release_targets(ids)
        if target is not None:
            self._targets.append((target, ids))
        self.leaves[ids] = self.remove_on_arrival if leave is None else bool(leave)
        self.goals[ids] = (self._aims(goal_region, self.positions[ids], self.leaves[ids], self.params["radius"][ids])
                           if arrive_anywhere else goal)
        self.anywhere[ids] = bool(arrive_anywhere)
        self.field_of[ids] = field
        self.arrival_time[ids] = np.nan
        self.packed[ids] = False
        self.deadlock.forget(ids)
        self.lanes.forget(ids)
        self._unchecked = np.concatenate([self._unchecked, ids])

    def add_goal_regions(self, regions) -> None:
        """Make the guidance fields of ``regions`` (Rect, Disc or Points) known before the
        first step, so that they are solved with the others, once, and a later
        :meth:`set_goals` or :meth:`walking_distance` to one of them re-solves nothing
        (a route's stages, say)."""
        for region in regions:
            if not _is_goal_region(region):
                raise ValueError(f"add_goal_regions: a Rect, Disc or Points region is needed, got {region!r}")
            added = self._regions_added
            place = self._region_index(region.nearest(self.positions[:1]) if len(self.positions) else None, region,
                                       solve=False)
            self._pinned.add(place)
            if self._regions_added > added:
                self._fields_stale = True

    @property
    def guidance_cell(self) -> float | None:
        """Metres of a guidance field cell as solved (``field_cell``, or its default from
        the agents' radius); None before any field is solved, or without field guidance."""
        return None if self._fields is None else float(self._fields.cell)

    def walking_distance(self, points, region) -> np.ndarray:
        """(K,) metres from each of ``points`` to ``region`` (Rect, Disc or Points): along
        the guidance field round the walls (the exact distances, not the congestion-weighted
        ones), or the straight line without a field; inf where walls close the way."""
        pts = finite_array(points, "points").reshape(-1, 2)
        straight = np.linalg.norm(region.nearest(pts) - pts, axis=1)
        self._ensure_fields()
        if self._fields is None:
            return straight
        field = self._region_index(region.nearest(pts[:1]) if len(pts) else None, region)
        self._require([field])
        exact = DistanceFields(self._exact, self._fields.origin, self._fields.cell, self._fields.blocked)
        return exact.nearby(field, pts)

    def remove_agents(self, agents) -> None:
        """Take agents out of the simulation now (the live API): they stop, nobody avoids
        them any more, and they count as not arrived. Their rows stay in the arrays."""
        ids = self._agent_ids(agents, "remove_agents")
        self.enter_at[ids[self.waiting[ids]]] = np.inf  # one still waiting never comes in
        self.active[ids] = False
        self.velocities[ids] = 0.0
        self.driven[ids] = False
        self.deadlock.forget(ids)
        self._release_targets(ids)

    def drive(self, agents, velocities) -> None:
        """Move agents yourself from the next step on (the live API): a game's player, a
        robot under its own controller. Each step a driven agent moves at the velocity
        given here (m/s; (2,) for all or one each), the last one given, until
        ``drive(agents, None)`` hands it back to the crowd's own steering. The crowd sees
        it as it sees a moving obstacle: every other agent avoids it along that velocity
        and expects no room from it (eq. (3)'s obstacle term, not the reciprocal one), and
        those it bears down on step aside first. A driven agent does not arrive, yield or
        slow, nor keep to its max_speed; the scene bounds hold it (it stops at the edge of
        the world), but nothing stops it walking into an obstacle or a body (the
        continuous audit reports it), so steer it with your own checks. Drive an agent
        right after adding it: one added on its goal arrives at the next step.

        Refused (ValueError, nothing changed): ids that do not exist, have left, are
        still waiting to enter or are given twice; a velocity that is NaN or inf."""
        ids = self._distinct_ids(agents, "drive")
        waiting = ids[self.waiting[ids]]
        if len(waiting):
            raise ValueError(f"drive: agent {int(waiting[0])} has not entered yet")
        if velocities is None:
            self.driven[ids] = False
            return
        self.drive_velocity[ids] = _xy_each(velocities, len(ids), "velocities")
        self.driven[ids] = True

    def place(self, agents, positions) -> None:
        """Put agents somewhere else now (the live API): a character the game teleported,
        a robot whose position its own localisation corrected. They keep their
        velocities, goals and routes. Refused (ValueError naming the agent, nothing
        moved) where a body would stick out of the scene bounds, lie in an obstacle
        standing now or overlap another agent in the scene, as ``add_agents`` refuses."""
        ids = self._distinct_ids(agents, "place")
        pos = _xy_each(positions, len(ids), "positions")
        self._check_placement(pos, self.params["radius"][ids], self.active[ids], ids)
        self.positions[ids] = pos
        self.placements.append((self.steps, ids.copy()))
        self.lanes.forget(ids)

    def _goal_points(self, goals, n: int) -> tuple[np.ndarray, MovingTarget | None]:
        """``goals`` ((2,), (n, 2) or a MovingTarget) as (n, 2) points now, and the target
        (None for points); ValueError naming the shape otherwise."""
        if isinstance(goals, MovingTarget):
            if goals.dim != 2:
                raise ValueError("goals: a 2D moving target is needed")
            return np.tile(goals.at(self.time), (n, 1)), goals
        xy = finite_array(goals, "goals")
        # one goal as a (1, 2) row (a slice of a goals array) is one goal for all
        return _xy_each(xy[0] if xy.shape == (1, 2) else xy, n, "goals"), None

    def _check_goal_region(self, region) -> None:
        """Refuse a goal region that is no Rect, Disc or Points region, or a group's
        MovingTarget (an obstacle shape given for one, say: the first step would fail on
        it, and every step after), and one with no part inside the scene bounds: its
        guidance field has no cell to start from, and before the first step it would
        have been taken in only to make every step after it fail."""
        if isinstance(region, MovingTarget):
            return  # (a group's moving goal: its agents chase it, with no field of their own)
        if not _is_goal_region(region):
            hint = {"Circle": " (the obstacle shape: a goal disc is crowdmotion.Disc)",
                    "Box": " (the obstacle shape: a goal rectangle is crowdmotion.Rect)",
                    "Lattice": " (a spawn region: a goal rectangle is crowdmotion.Rect)"}.get(type(region).__name__, "")
            raise ValueError(f"goal_region: a Rect, Disc or Points region is needed, got {region!r}{hint}")
        lo, hi = self.scene.lower, self.scene.upper
        if isinstance(region, Rect):
            inside = bool(np.all(region.lower[:2] <= hi) and np.all(region.upper[:2] >= lo))
        elif isinstance(region, Disc):
            inside = bool(np.linalg.norm(region.center[:2] - np.clip(region.center[:2], lo, hi)) <= region.radius)
        elif isinstance(region, Points):
            inside = bool(np.any(np.all((region.points[:, :2] >= lo) & (region.points[:, :2] <= hi), axis=1)))
        else:
            return
        if not inside:
            raise ValueError(f"goal_region: {region!r} lies outside the scene bounds {lo.tolist()}-{hi.tolist()}")

    def _standing_goals(self, goal: np.ndarray, radius: np.ndarray, goal_region) -> np.ndarray:
        """``goal`` with each point a body of its agent's ``radius`` cannot stand on
        (closer to the scene's edge or a static obstacle than the radius) moved the least
        way to where it fits (``placement.standing_points``): eq. (3) would stand such an
        agent metres short of it for good. A point drawn in a Rect or Disc goal region
        (a point of an exit strip along the scene's edge, say) moves quietly; points named
        as such (no region, or Points) with a warning naming the first. Points outside
        the bounds or inside an obstacle are refused (ValueError) as before."""
        if goal_region is None:
            self._check_goal_points(goal)
        moved = standing_points(self._now, goal, radius)
        off = np.flatnonzero(np.any(moved != goal, axis=1))
        if len(off) and not isinstance(goal_region, (Rect, Disc)):
            i = int(off[0])
            which = f"{goal[i].tolist()}, of the {_ordinal(i)} of {len(goal)} agents (radius {radius[i]:g} m)"
            warnings.warn(("goals: the goal point " + which + " lies" if len(off) == 1 else
                           f"goals: {len(off)} goal points lie") + " closer to a wall or the scene's edge than the "
                          f"agent's radius{'' if len(off) == 1 else ' (the first: ' + which + ')'}: no body stands "
                          f"there, and the agent may stop short of it for good. Moved the least way to where the "
                          f"body fits ({'' if len(off) == 1 else 'the first '}to {np.round(moved[i], 3).tolist()})",
                          UserWarning, stacklevel=3)
        return moved

    def _check_goal_points(self, goal: np.ndarray) -> None:
        """Refuse goal points that are their own goal region (no ``goal_region`` given) and
        that no body can reach: outside the bounds (walked at forever) or inside an obstacle
        (its guidance field unsolvable, every later step refused)."""
        n = len(goal)
        out = np.flatnonzero(np.any((goal < self.scene.lower) | (goal > self.scene.upper), axis=1))
        if len(out):
            i = int(out[0])
            raise ValueError(f"goals: {goal[i].tolist()} (the {_ordinal(i)} of {n}) lies outside the scene bounds "
                             f"{self.scene.lower.tolist()}-{self.scene.upper.tolist()}")
        inside = np.flatnonzero(self._now.static_obstacle_distance(goal) < 0)
        if len(inside):
            i = int(inside[0])
            raise ValueError(f"goals: {goal[i].tolist()} (the {_ordinal(i)} of {n}) lies inside an obstacle")

    def _release_targets(self, ids: np.ndarray) -> None:
        """Agents ``ids`` no longer chase the moving targets they did."""
        self._targets = [(t, held[~np.isin(held, ids)]) for t, held in self._targets]
        self._targets = [(t, held) for t, held in self._targets if len(held)]

    def _nearest_goals(self) -> None:
        """Agents that arrive anywhere in their goal region head for its nearest point (those
        that leave there, for the nearest point ``LEAVE_INSET_M`` inside it)."""
        walking = self.anywhere & self.active
        if not walking.any():
            return
        for k in np.unique(self.field_of[walking]):
            ids = np.flatnonzero(walking & (self.field_of == k))
            self.goals[ids] = self._aims(self._goal_regions[k], self.positions[ids], self.leaves[ids],
                                         self.params["radius"][ids])

    def _aims(self, region, points: np.ndarray, leaving: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """The goal points of agents at ``points`` that arrive anywhere in ``region`` (a Rect
        or Disc): its nearest point, or for those ``leaving`` there the nearest point
        ``LEAVE_INSET_M`` inside it, moved to where a body of ``radius`` fits."""
        out = region.nearest(points)
        if leaving.any():
            aims, r = _inset_nearest(region, points[leaving]), radius[leaving]
            if r.max() + GOAL_CLEARANCE_M > self._inset_clearance(region):  # some may not fit
                aims = standing_points(self._now, aims, r)
            out[leaving] = aims
        return out

    def _inset_clearance(self, region) -> float:
        """A lower bound of the clearance of every point of ``region`` shrunk by
        ``LEAVE_INSET_M`` from the scene's edge and the static obstacles (their boxes): a
        body of a smaller radius fits at every aim point there as it is (a safe area in
        the open, an exit area behind a door), and none need moving, step after step."""
        statics = self._now.static_obstacles
        key = (repr(region), tuple(map(id, statics)))
        if key not in self._inset_clear:
            lo, hi = _inset_box(region)
            clear = float(min(self._now.wall_clearance(lo), self._now.wall_clearance(hi)))  # its corners
            for ob in statics:
                olo, ohi = ob.bounds()
                clear = min(clear, float(np.linalg.norm(np.maximum(0.0, np.maximum(olo - hi, lo - ohi)))))
            self._inset_clear[key] = clear
        return self._inset_clear[key]

    @property
    def waiting(self) -> np.ndarray:
        """(N,) agents not yet in the scene: not due yet, or due but with no room where
        they enter."""
        return np.isnan(self.entry_time) & np.isfinite(self.enter_at)

    def set_entry_points(self, agents, points) -> None:
        """Where waiting agents will enter (a fresh free spot of an entrance, say): (2,)
        or one point each, inside the bounds and clear of static obstacles."""
        ids = self._known_ids(agents, "set_entry_points")
        entered = ids[~self.waiting[ids]]
        if len(entered):
            raise ValueError(f"set_entry_points: agent {int(entered[0])} has entered already")
        pts = _xy_each(points, len(ids), "points")
        self._check_placement(pts, self.params["radius"][ids], np.zeros(len(ids), dtype=bool), ids)
        self.positions[ids] = pts

    def _admit(self) -> None:
        """Let in the waiting agents that are due and whose place is free: nobody (still
        in, leaving there in this very step and so drawn in its frame, or let in before
        them this step, earliest due first) within their bodies plus ENTRY_GAP_M, and no
        obstacle standing there now."""
        due = np.flatnonzero(self.waiting & (self.enter_at <= self.time + 1e-9))
        if not len(due):
            return
        due = due[np.argsort(self.enter_at[due], kind="stable")]
        rad = self.params["radius"]
        pos = self.positions[due]
        ok = self._now.obstacle_distance(pos, self.time) >= rad[due]
        live = np.flatnonzero(self.present)
        if len(live):  # the gap to the ENTRY_NEIGHBOURS nearest bodies still in (or leaving in this frame)
            d, j = cKDTree(self.positions[live]).query(pos, k=min(ENTRY_NEIGHBOURS, len(live)))
            d, j = d.reshape(len(due), -1), j.reshape(len(due), -1)
            ok &= (d - rad[live][j] - rad[due][:, None]).min(axis=1) >= ENTRY_GAP_M
        cand = np.flatnonzero(ok)
        if len(cand) > 1:  # among themselves: the earlier due goes first
            pairs = cKDTree(pos[cand]).query_pairs(2 * rad[due].max() + ENTRY_GAP_M, output_type="ndarray")
            for a, b in pairs[np.argsort(pairs.max(axis=1))]:
                ia, ib = cand[a], cand[b]
                if ok[ia] and ok[ib] and np.linalg.norm(pos[ia] - pos[ib]) < rad[due[ia]] + rad[due[ib]] + ENTRY_GAP_M:
                    ok[max(ia, ib)] = False
        now = due[ok]
        self.active[now] = True
        self.velocities[now] = 0.0
        self._facing[now] = _heading(self.goals[now] - self.positions[now])  # from where it enters
        self.entry_time[now] = self.time

    def _bodies(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The agents in the scene now (ids, positions, radii): no obstacle goes in on them."""
        live = np.flatnonzero(self.active)
        return live, self.positions[live], self.params["radius"][live]

    def _obstacles_rebuilt(self, now: Scene) -> None:
        """Rebuild what the obstacles standing now shape: primitives, guidance fields, floor."""
        self.obstacles = ObstacleSet(now)
        self.density_slowing.refloor(now)
        self._fields_stale = True  # rebuilt (for the obstacles standing now) when next needed

    def _obstacles_check(self) -> None:
        """A new obstacle's guidance fields solved now: a goal it covers raises here."""
        self._ensure_fields()

    def _agent_ids(self, agents, what: str) -> np.ndarray:
        """``agents`` as unique int ids of agents still in the simulation or waiting to
        enter, in the order given (so per-agent goals stay with their agents; a repeat is
        dropped), ValueError otherwise."""
        raw = self._known_ids(agents, what)
        ids = raw[np.sort(np.unique(raw, return_index=True)[1])]
        gone = ids[~self.active[ids] & ~self.waiting[ids]]
        if len(gone):
            raise ValueError(f"{what}: agent {int(gone[0])} has left the simulation")
        return ids

    def _distinct_ids(self, agents, what: str) -> np.ndarray:
        """:meth:`_agent_ids`, refusing an id given twice (the values given are one per id)."""
        raw = self._known_ids(agents, what)
        values, counts = np.unique(raw, return_counts=True)
        if (counts > 1).any():
            raise ValueError(f"{what}: agent {int(values[counts > 1][0])} is given twice")
        return self._agent_ids(raw, what)

    def _known_ids(self, agents, what: str) -> np.ndarray:
        """``agents`` as int ids of agents the simulator has (ValueError naming ``what`` otherwise)."""
        raw = np.atleast_1d(np.asarray(agents))
        if raw.ndim != 1 or (raw.size and not np.issubdtype(raw.dtype, np.integer)):
            raise ValueError(f"{what}: agents must be a list of agent ids (integers), got {agents!r}")
        ids = raw.astype(np.int64)
        bad = ids[(ids < 0) | (ids >= self.n_agents)]
        if len(bad):
            raise ValueError(f"{what}: no agent {int(bad[0])} ({id_range(self.n_agents)})")
        return ids

    def _field_indices(self, goal: np.ndarray, goal_region, solve: bool = True) -> np.ndarray:
        """(n,) the guidance field each of ``goal``'s agents follows: the region's, or
        without one, each goal point's own (up to ``OWN_FIELDS_MAX`` different points in
        one call; more are grouped by place into ``OWN_FIELDS_MAX`` groups sharing a field
        each, with a warning: where its goal is out of sight an agent then heads for the
        nearest goal of its group, and at the end of that field for its own
        (:meth:`_own_fields`))."""
        n = len(goal)
        if goal_region is not None or n == 0:
            return np.full(n, self._region_index(goal, goal_region, solve))
        self._check_goal_points(goal)
        points, which = np.unique(goal, axis=0, return_inverse=True)
        if len(points) == 1:
            return np.full(n, self._region_index(goal, None, solve))
        if len(points) > OWN_FIELDS_MAX:
            near = _nearby_groups(points, OWN_FIELDS_MAX)
            if self._use_field():
                warnings.warn(f"{len(points)} different goal points in one call share {near.max() + 1} guidance "
                              f"fields, one per group of nearby goals (more than {OWN_FIELDS_MAX} points): where its "
                              "own goal is out of sight an agent heads for the nearest goal of its group, then along its "
                              "own goal's field; give a goal_region, or add the agents in calls of fewer goal points",
                              stacklevel=3)
            own = self._region_indices([_points_region(points[near == g]) for g in range(near.max() + 1)], solve)
            self._grouped.update(own.tolist())
            return own[near[np.ravel(which)]]
        own = self._region_indices([_points_region(pt[None, :]) for pt in points], solve)
        return own[np.ravel(which)]

    def _region_indices(self, regions: list, solve: bool) -> np.ndarray:
        """The index of each goal region among those known (by value: a region given again
        reuses its field), adding the new ones, in the places of fields nobody uses any more
        where :meth:`_reusable` gives some; with ``solve``, once fields exist, the new
        ones' fields are solved together (one raster of the obstacles for all) and known
        ones a rebuild left for later are solved (a goal an obstacle now covers raises)."""
        keys = [(type(r).__name__, repr(r)) for r in regions]
        new = [k for k, key in enumerate(keys) if key not in self._region_keys and key not in keys[:k]]
        if new:
            known = [self._region_keys.index(key) for key in keys if key in self._region_keys]
            places = self._reusable(len(new), known)
            places += range(len(self._goal_regions), len(self._goal_regions) + len(new) - len(places))
            solving = solve and self._fields is not None and not self._fields_stale
            if solving:  # a bad goal raises here, before any change
                self._add_fields([regions[k] for k in new], places)
            for k, place in zip(new, places):
                if place < len(self._goal_regions):
                    self._forget_field(place)
                    if not solving and self._fields is not None and place < len(self._solved):
                        self._solved[place] = False  # its new region's field: solved when next used
                    self._goal_regions[place] = regions[k]
                    self._region_keys[place] = keys[k]
                else:
                    self._goal_regions.append(regions[k])
                    self._region_keys.append(keys[k])
                    self._asked_at.append(self.steps)
            self._regions_added += len(new)
        out = np.array([self._region_keys.index(key) for key in keys], dtype=np.int64)
        for k in out.tolist():
            self._asked_at[k] = self.steps
        if solve and not self._fields_stale:
            self._require(out)
        return out

    def _reusable(self, count: int, asked: list) -> list:
        """Up to ``count`` places of fields that no agent in the scene or waiting walks to,
        not pinned, not re-solving this period and not among ``asked``, beyond the
        ``UNUSED_FIELDS_MB`` of such fields kept (at least ``UNUSED_FIELDS_MIN``): the
        longest unused first."""
        n = len(self._goal_regions)
        idle = np.ones(n, dtype=bool)
        idle[self.field_of[self.active | self.waiting]] = False
        idle[list(self._pinned)] = False
        idle[asked] = False
        if self._replanning is not None:
            idle[self._replanning[0]] = False
        free = np.flatnonzero(idle)
        kept = UNUSED_FIELDS_MIN
        if self._fields is not None and len(self._exact):
            field_bytes = self._exact[0].nbytes * (1 if self._fields.dist is self._exact else 2)
            kept = max(kept, int(UNUSED_FIELDS_MB * 1e6 // field_bytes))
        if len(free) <= kept:
            return []
        oldest = free[np.argsort(np.asarray(self._asked_at)[free], kind="stable")]
        return oldest[:min(count, len(free) - kept)].tolist()

    def _forget_field(self, place: int) -> None:
        """The goal region in ``place`` gives its place to another: nothing refers to it."""
        self._region_ids = {obj: k for obj, k in self._region_ids.items() if k != place}
        self._grouped.discard(place)

    def _add_fields(self, regions: list, places: list) -> None:
        """Solve the fields of new goal regions, into ``places``: those of fields no longer
        used, then new ones beside those already solved."""
        more = distance_fields(self._now, regions, float(self.params["radius"].max()),
                               names=[f"goal region {k}" for k in places], like=self._fields)
        reused = [k for k in places if k < len(self._exact)]
        if reused:
            self._store_fields(reused, more.dist[:len(reused)], more.goal_cells[:len(reused)])
        grown = more.dist[len(reused):]
        if len(grown):
            same = self._fields.dist is self._exact
            self._exact = _stacked(self._exact, grown)
            self._fields.dist = self._exact if same else _stacked(self._fields.dist, grown)
            self._fields.goal_cells.extend(more.goal_cells[len(reused):])
            self._solved = np.concatenate([self._solved, np.ones(len(grown), dtype=bool)])

    def _store_fields(self, places, dist: np.ndarray, goal_cells: list) -> None:
        """Solved exact fields ``dist`` of the goal regions in ``places``."""
        self._exact[places] = dist
        if self._fields.dist is not self._exact:
            self._fields.dist[places] = dist
        for k, c in zip(places, goal_cells):
            self._fields.goal_cells[k] = c
        self._solved[places] = True
        self._forget_partial(places)
        self._weighted.difference_update(np.atleast_1d(places).tolist())

    def _region_index(self, goal: np.ndarray, goal_region, solve: bool = True) -> int:
        """The index of the goal region (``goal_region``, or the goal points) among those
        known, adding it if it is new (:meth:`_region_indices`); a region object given
        before is found by its id, without its repr."""
        if goal_region is not None and id(goal_region) in self._region_ids:
            index = self._region_ids[id(goal_region)]
            self._asked_at[index] = self.steps
            if solve and not self._fields_stale:
                self._require([index])
            return index
        region = goal_region if goal_region is not None else _points_region(goal)
        index = int(self._region_indices([region], solve)[0])
        if goal_region is not None and self._goal_regions[index] is goal_region:  # held there: its id stays its own
            self._region_ids[id(goal_region)] = index
        return index

    def _check_placement(self, pos: np.ndarray, rad: np.ndarray, now: np.ndarray | None = None,
                         ids: np.ndarray | None = None) -> None:
        """Refuse agents that start inside an obstacle, outside the bounds or (those
        entering ``now``, default all) overlapping another (two agents already in the
        scene that touch, a driven player pressing into someone, are theirs to sort out).
        ``ids``: the agents placed anew (default: new agents, numbered on from the last)."""
        new = ids is None
        ids = self.n_agents + np.arange(len(pos)) if new else ids
        inside = np.minimum(pos - self.scene.lower, self.scene.upper - pos).min(axis=1) - rad
        bad = np.flatnonzero(inside < 0)
        if len(bad):
            i = int(bad[0])
            raise ValueError(f"agent {ids[i]} at {pos[i].tolist()} (radius {rad[i]}) does not fit inside "
                             f"the scene bounds {self.scene.lower.tolist()}-{self.scene.upper.tolist()}")
        clear = self._now.obstacle_distance(pos, self.time) - rad
        bad = np.flatnonzero(clear < 0)
        if len(bad):
            i = int(bad[0])
            raise ValueError(f"agent {ids[i]} at {pos[i].tolist()} {'starts' if new else 'would be'} inside an "
                             f"obstacle (penetration {-clear[i]:.3f} m)")
        live = np.flatnonzero(self.active & ~np.isin(np.arange(self.n_agents), ids))
        now = np.ones(len(pos), dtype=bool) if now is None else now
        if not now.any():
            return
        allpos = np.concatenate([self.positions[live], pos[now]])
        allrad = np.concatenate([self.params["radius"][live], rad[now]])
        ids = np.concatenate([live, ids[now]])
        pairs = cKDTree(allpos).query_pairs(2 * allrad.max(), output_type="ndarray")
        pairs = pairs[pairs.max(axis=1) >= len(live)] if len(pairs) else pairs  # two already in touch are no concern here
        if len(pairs):
            d = np.linalg.norm(allpos[pairs[:, 0]] - allpos[pairs[:, 1]], axis=1)
            hit = np.flatnonzero(d < allrad[pairs[:, 0]] + allrad[pairs[:, 1]])
            if len(hit):
                a, b = pairs[hit[0]]
                named = [f"{ids[k]}{' (being added)' if new and ids[k] >= self.n_agents else ''}" for k in (a, b)]
                raise ValueError(f"agents {named[0]} and {named[1]} {'start' if new else 'would be'} overlapped: "
                                 f"centres {d[hit[0]]:.3f} m apart, radii sum {allrad[a] + allrad[b]:.3f} m")

    # ---- stepping ----------------------------------------------------------------------
    def _use_field(self) -> bool:
        if self.guidance == "field":
            return True
        return self.guidance == "auto" and bool(self._now.static_obstacles)

    def _ensure_fields(self) -> None:
        """The guidance fields for the obstacles standing now: at the first build every
        goal region's; at a rebuild (an obstacle came or went, a wider body) only those
        of the regions agents walk to or wait to, the others when next used
        (:meth:`_require`), so that a game whose goals piled up pays for those in use."""
        if not self._fields_stale:
            return
        rebuild = self._fields is not None
        # none of them once the last static obstacle went (auto guidance)
        self._fields = self._router = self._weights = self._replanning = None
        self._partial, self._weighted = set(), set()
        if self._use_field() and self.n_agents:
            regions = np.arange(len(self._goal_regions))
            if rebuild:
                regions = np.unique(self.field_of[self.active | self.waiting])
            fields = distance_fields(self._now, [self._goal_regions[k] for k in regions],
                                     float(self.params["radius"].max()), self.field_cell,
                                     names=[f"goal region {k}" for k in regions] if rebuild else None)
            if len(regions) < len(self._goal_regions):
                dist = np.full((len(self._goal_regions),) + fields.blocked.shape, np.inf)
                dist[regions] = fields.dist
                cells: list = [None] * len(self._goal_regions)
                for k, c in zip(regions, fields.goal_cells):
                    cells[k] = c
                fields.dist, fields.goal_cells = dist, cells
            self._fields = fields
            self._exact = fields.dist
            self._solved = np.zeros(len(self._goal_regions), dtype=bool)
            self._solved[regions] = True
            self._router = CongestionRouter(self._fields, self.congestion, self.counterflow,
                                            keep_right=self.deadlock.keep_right > 0)
        self._fields_stale = False

    def _require(self, regions) -> None:
        """Solve the fields of ``regions`` (indices) a rebuild left for later."""
        if self._fields is None or self._solved.all():  # the usual step: nothing left for later
            return
        regions = np.unique(np.asarray(regions, dtype=np.int64))
        todo = regions[~self._solved[regions]]
        if not len(todo):
            return
        more = distance_fields(self._now, [self._goal_regions[k] for k in todo], float(self.params["radius"].max()),
                               names=[f"goal region {k}" for k in todo], like=self._fields)  # a goal covered now raises
        self._store_fields(todo, more.dist, more.goal_cells)

    def _replan(self) -> None:
        """Re-solve the congestion-aware fields every ``replan_s``, from the crowd as it is
        at the period's first step. With steps shorter than ``REPLAN_SPREAD_S`` (a game's
        frames), the Dijkstras are cut into slices spread over the steps of that first
        ``REPLAN_SPREAD_S``, or over more steps (up to the period) where the fields hold
        more than ``REPLAN_CELLS_PER_STEP`` cells a step: the same share of cells settled
        each step, one field or many, and each field's cells near its agents found and its
        solved round marked as its search begins and ends, so that no frame pays for them
        all (200 wanderers, each with a goal of its own, stuttered for 5 frames of 35-60 ms
        every 2 s at 30 frames a second). The new fields are taken all at once when the
        last is done, so that every group's field answers the same crowd (taken one by
        one, the roadmap crowd of RVO2's example gridlocked). At the default step they are
        all solved and taken in the period's first step. A field nobody walks goes back to
        its exact distances."""
        if self._router is None or not self._router.enabled:
            return
        if self.steps % self.replan_steps == 0:
            if not self.active.any():
                self._replanning = None
                self._fields.dist = self._exact
                self._partial, self._weighted = set(), set()
                return
            self._weights = self._router.weights(self.positions[self.active], self.velocities[self.active])
            todo = np.unique(self.field_of[self.active])
            cells = len(todo) * len(self._router.graph.cell_index)  # what the searches settle at most
            spread = min(self.replan_steps, max(1, int(round(REPLAN_SPREAD_S / self.dt))))
            if spread > 1:
                spread = min(self.replan_steps, max(spread, -(-cells // REPLAN_CELLS_PER_STEP)))
            # each field solved as far as its agents (in or waiting) walk or look before the
            # next fields are taken (_complete_partial catches any that go farther)
            reach = self.params["max_speed"].max() * (self.replan_steps + spread + 1) * self.dt + \
                (field_window(self._fields.cell) + 2) * self._fields.cell
            present = self.active | self.waiting
            crowd = (self.positions[present].copy(), self.field_of[present].copy(), reach)
            if spread == 1:
                self._replanning = None
                near = [self._near(crowd, k) for k in todo.tolist()]
                self._take(dict(zip(todo.tolist(), self._router.solve(None, todo, weights=self._weights, near=near))))
                return
            self._replanning = (todo, crowd, -(-cells // spread), {}, {})
        if self._replanning is None:
            return
        todo, crowd, share, searches, solved = self._replanning  # this step settles its share of cells
        for k in todo.tolist():
            if k in solved:
                continue
            search = searches.get(k)
            if search is None:  # its search begins: the cells near its agents at the period's start
                search = searches[k] = self._router.searches([k], self._weights, [self._near(crowd, k)])[0]
            before = search.settled
            search.advance(share)
            share -= search.settled - before
            if search.done:
                d = search.distances()
                solved[k] = (d, self._solved_round_of(k, d))
                del searches[k]
            if share <= 0:
                break
        if len(solved) == len(todo):
            self._replanning = None
            self._take({k: d for k, (d, _) in solved.items()}, {k: r for k, (_, r) in solved.items()})

    def _near(self, crowd: tuple, k: int) -> np.ndarray:
        """The cells field ``k``'s search must settle: within ``reach`` of its agents in
        ``crowd`` (positions, their fields, reach)."""
        pos, field_of, reach = crowd
        return self._router.near(pos[field_of == k], reach)

    def _solved_round_of(self, k: int, dist: np.ndarray) -> np.ndarray:
        """Where an agent's window along field ``k`` (and a cell more) holds only cells
        ``dist`` solved, or cells no field reaches: it reads what the whole search gives."""
        size = 2 * (field_window(self._fields.cell) + 1) + 1
        return minimum_filter(np.isfinite(dist) | ~np.isfinite(self._exact[k]), size=size, mode="nearest")

    def _take(self, solved: dict, rounds: dict | None = None) -> None:
        """The congestion-aware fields ``solved`` (field -> distances) of this period
        taken, all at once; the others exact again. ``rounds``: each field's
        :meth:`_solved_round_of`, where already found."""
        dist = self._fields.dist
        if dist is self._exact:
            dist = self._exact.copy()
        else:  # the last period's array: exact again where no longer weighted
            for k in self._weighted.difference(solved):
                dist[k] = self._exact[k]
        for k, d in solved.items():
            dist[k] = d
        self._fields.dist = dist
        self._weighted = set(solved)
        self._partial, self._partial_weights = set(solved), self._weights
        self._solved_round = np.ones(dist.shape, dtype=bool)
        for k in solved:
            self._solved_round[k] = rounds[k] if rounds else self._solved_round_of(k, dist[k])

    def _complete_partial(self) -> None:
        """Solve to the end the congestion-aware fields, solved only near their agents, that
        an agent now reads beyond what was solved: one placed, driven or sent there since."""
        if not self._partial:
            return
        f = self._fields
        ids = np.flatnonzero(self.active)
        fo = self.field_of[ids]
        rows = len(self._solved_round)
        cells = f.cell_of(self.positions[ids])
        fine = self._solved_round[np.minimum(fo, rows - 1), cells[:, 0], cells[:, 1]] | (fo >= rows)
        for k in np.unique(fo[~fine]).tolist():
            f.dist[k] = self._router.solve(None, np.array([k]), weights=self._partial_weights)[0]
            self._forget_partial([k])

    def _forget_partial(self, fields) -> None:
        """The fields ``fields`` (indices) hold distances solved to the end now."""
        for k in np.atleast_1d(fields).tolist():
            if k in self._partial:
                self._partial.discard(k)
                self._solved_round[k] = True

    def preferred_velocities(self) -> np.ndarray:
        """(N, 2) v_pref of every agent now (zero for agents that left)."""
        return self._guidance(self.obstacles.at(self.time, self.dt))[0]

    def _guidance(self, prims) -> tuple[np.ndarray, np.ndarray]:
        """v_pref and the distance to each agent's aim point, with obstacles placed now."""
        self._ensure_fields()
        self._require(self.field_of[self.active])
        self._replan()
        self._complete_partial()
        for target, ids in self._targets:
            self.goals[ids] = target.at(self.time)
        self._nearest_goals()
        lost = np.zeros(self.n_agents, dtype=bool) if self._grouped else None  # only a shared field ends elsewhere
        v, aim = preferred_velocities(self.positions, self._aim_points(), self.params["pref_speed"], self.active, self.dt,
                                      self._fields, self.field_of, prims, self.params["radius"], lost)
        v[~self.active] = 0.0
        if lost is not None and lost.any():
            self._own_fields(lost)
        return v, aim

    def _own_fields(self, lost: np.ndarray) -> None:
        """Agents of a group of nearby goals sharing a field (``_field_indices``) that
        find no way on along it, their own goal out of sight (it ends at another's goal,
        theirs behind a wall), get their own goal's field from the next step on; one
        whose goal an obstacle has since covered keeps the group's."""
        for i in np.flatnonzero(lost & np.isin(self.field_of, list(self._grouped))):
            key = (i, *self.goals[i])
            if key in self._no_own_field:
                continue
            try:
                self.field_of[i] = self._region_index(self.goals[i][None], None)
            except ValueError:  # no free cell at its goal now: not tried again for this goal
                self._no_own_field.add(key)

    def _grid(self, agents: np.ndarray):
        """A uniform grid over ``agents`` (a mask), cells wide enough for the step check."""
        return grid_for(self.positions, agents, self.params["radius"], self.params["max_speed"], self.dt)

    def set_route(self, agents, route) -> None:
        """Send agents along a route of stages from now on (the live API): ``route`` is a
        list of :mod:`crowdmotion.stages` stages (GoTo, Wait, Queue, Choose, Leave), as a
        scenario's ``[[groups.route]]`` gives them (a Choose's options may be branches:
        lists of stages). Each step then moves the agents on
        along it (``sim.journeys``, a :class:`crowdmotion.journeys.Journeys`, holds where
        each is: ``sim.journeys.stage``). Agents on another route leave its stage at once
        (a queue closes up behind them); agents still waiting to enter begin it on entering.

        Refused (ValueError naming the stage, ``set_route: route.1 (queue 'gate'): ...``,
        nothing changed) as a scenario's route is: stages out of order, an area outside
        the scene or covered by obstacles standing now, queue places that do not fit a
        line of these agents."""
        ids = self._agent_ids(agents, "set_route")
        if not len(ids):
            return
        if self.journeys is None:
            from crowdmotion._rng import step_key
            from crowdmotion.journeys import Journeys

            self.journeys = Journeys([None], np.zeros(self.n_agents, dtype=np.int64), [None], self.params["radius"],
                                     self.params["pref_speed"], step_key(self.rng), self._clearance)
        self.journeys.set_route(ids, route, self, self.params["radius"], self.params["pref_speed"],
                                check=self._check_route)

    def _check_route(self, route, ids: np.ndarray) -> None:
        """A route's places checked against the scene standing now, as a scenario's are."""
        from crowdmotion.checks import check_live_route

        check_live_route(self._now, route, len(ids), float(self.params["radius"][ids].max()), self.positions[ids[0]],
                         "set_route")

    def prepare(self) -> None:
        """Solve now what the next step would first have to: the guidance fields of the
        goals given (with field guidance), so that a game can pay for them behind its
        loading screen rather than in its first frame (1000 walkers bound for four exits
        of an 80 x 80 m square: the first step 179 ms, or 31 ms after ``prepare()``, which
        took 111 ms). Goals, agents and obstacles may still be changed afterwards (what
        they change is solved when next needed, as always); calling it again does
        nothing new."""
        self._ensure_fields()

    def step(self) -> None:
        """Advance every agent by one time step (all choose at once, then all move), then
        move agents on along their routes (``journeys``). A ValueError, before anything
        moves, if an active agent's position, velocity or goal is NaN or inf (the kernels
        would crash on it)."""
        self._advance()
        if self.journeys is not None:
            self.journeys.update(self, self.dt)

    def _advance(self) -> None:
        require_finite_agents({"positions": self.positions, "velocities": self.velocities, "goals": self.goals},
                              self.active)
        n = self.n_agents
        if n == 0 or not self.active.any():
            self.steps += 1
            self._admit()
            return
        prims = self.obstacles.at(self.time, self.dt)
        wanted, aim = self._guidance(prims)
        self._warn_unreachable()
        p = self.params
        driven = self.driven & self.active
        steer = self.active  # the agents whose velocity the crowd's choice sets
        if driven.any():  # the others avoid a driven one as a moving disc: it makes no room
            steer = self.active & ~driven
            prims = prims.with_discs(self.positions[driven], p["radius"][driven], self.drive_velocity[driven])
        new = self._choose(prims, wanted, aim, steer, driven) if steer.any() else np.zeros((n, 2))
        self.stats["agent_steps"] += int(self.active.sum())
        if driven.any():  # as driven, but never out of the world: the bounds hold their bodies
            r = p["radius"][driven, None]
            at = self.positions[driven]
            to = np.clip(at + self.drive_velocity[driven] * self.dt, self.scene.lower + r, self.scene.upper - r)
            new[driven] = (to - at) / self.dt
        self.positions = self.positions + new * self.dt
        self.velocities = new
        self._facing = turn_towards(self._facing, new, STANDING_FRACTION * p["pref_speed"], MAX_TURN_RATE * self.dt,
                                    self.active)
        self.steps += 1
        if steer.any():
            self.stats["yields"] += self.deadlock.update(self.positions, wanted, new, p["pref_speed"], p["radius"],
                                                         p["neighbor_dist"], steer, self.dt, self.goals)
        self._arrivals()
        self._admit()

    def _choose(self, prims, wanted: np.ndarray, aim: np.ndarray, steer: np.ndarray,
                driven: np.ndarray) -> np.ndarray:
        """(N, 2) the velocities the ``steer`` agents choose this step (eq. (3) with the
        named terms, then the safety pass); zero for the others."""
        n = self.n_agents
        p = self.params
        dl = self.deadlock
        grid = self._grid(steer)
        slow = self.density_slowing.factors(self.positions, self.velocities, wanted, p["radius"], steer, grid, self.dt,
                                            self.goals)
        safety = p["safety"] * self.density_slowing.safety_factors(self.counterflow_safety)
        vpref = dl.yielding_velocities(self.positions, wanted, p["pref_speed"], p["radius"], steer, grid, prims)
        if self.lane_choice:
            vpref = self.lanes.velocities(self.positions, self.velocities, vpref, p["radius"], p["safety"],
                                          self.density, steer, grid, prims, self.goals)
        vpref = vpref * slow[:, None]
        if self.comfort_accel > 0.0:
            vpref = self._turned_in(vpref)
        new = np.zeros((n, 2))
        forced = np.zeros(n, dtype=bool)
        key = step_key(self.rng)
        K.choose_velocities(self.positions, self.velocities, vpref, aim, p["radius"], p["max_speed"],
                            p["max_neighbors"], p["neighbor_dist"], p["samples"], safety,
                            steer, *grid, prims.circ_c, prims.circ_r, prims.circ_v, prims.seg_a, prims.seg_b,
                            prims.seg_v, self.dt, key, new, forced, dl.keep_right, KEEP_RIGHT_LOOK_S,
                            self.follow * np.minimum(self.density / FOLLOW_FULL_DENSITY, 1.0),
                            self._comfort_reach(), self.goals,
                            self._leave_reach(), self._squeeze_s(), SQUEEZE_SIDE_M, self._parked(), self.deadlock.still,
                            self._held_s())
        # safety: of two agents that would touch during the step, the one with the lower
        # (random, per step) priority stands still instead, until none would
        # agents a moving obstacle bears down on go first: standing still is no refuge for them
        threatened = self._threatened(prims, driven)
        self.stats["safety_stops"] += K.resolve_conflicts(self.positions, new, p["radius"], steer,
                                                          self.rng.random(n) + threatened, *grid, self.dt)
        if threatened.any():  # and one the pass stopped in a moving obstacle's way steps aside
            self.stats["escapes"] += K.escape_moving_obstacles(
                self.positions, new, vpref, p["radius"], p["max_speed"], threatened > 0, *grid, prims.circ_c,
                prims.circ_r, prims.circ_v, prims.seg_a, prims.seg_b, prims.seg_v, self.dt, ESCAPE_HEADINGS)
        self.stats["forced_choices"] += int(forced[steer].sum())
        return new

    def _parked(self) -> np.ndarray:
        """(N,) agents that have arrived and stay (waiting, queueing, gathered): the others
        pass them as they would a standing obstacle (``K.choose_velocities``); none with
        ``pass_standing`` off."""
        return self.active & ~self.leaves & ~np.isnan(self.arrival_time) & self.pass_standing

    def _squeeze_s(self) -> np.ndarray:
        """(N,) seconds within which a walker squeezing past an oncoming one counts a
        wall's collision (:mod:`crowdmotion.rvo.deadlock`, rule 1); inf where it counts
        them all: bodies wider than a person (robots, vehicles), or ``squeeze_past`` off."""
        person = self.params["radius"] <= SQUEEZE_MAX_RADIUS_M
        return np.where(person & self.squeeze_past, SQUEEZE_WALL_S, np.inf)

    def _held_s(self) -> np.ndarray:
        """(N,) seconds standing held up from which a walker counts a neighbour's collision
        only when met within ``_kernels.HELD_HORIZON_S``; inf for bodies wider than a
        person, or with ``held_horizon`` off."""
        person = self.params["radius"] <= PERSON_MAX_RADIUS_M
        return np.where(person & self.held_horizon, K.HELD_LONG_S, np.inf)

    def _comfort_reach(self) -> np.ndarray:
        """(N,) the change of velocity (m/s) each agent makes comfortably this step: the
        comfortable acceleration × dt, faster while breaking a stand-off; 0 (no limit) for
        bodies wider than a person (robots, vehicles: eq. (3) alone)."""
        person = self.params["radius"] <= PERSON_MAX_RADIUS_M
        return np.where(person, self.comfort_accel * self.dt * np.where(self.deadlock.breaking(), BRISK, 1.0), 0.0)

    @property
    def _exiting(self) -> np.ndarray:
        """(N,) agents that leave on entering their goal region (an exit, a safe area)."""
        return self.anywhere & self.leaves

    def _leave_reach(self) -> np.ndarray:
        """(N,) how near its goal point a move must bring an agent for it to leave within
        the step (the choice then ignores what it would meet after): ``arrival_radius`` for
        those that leave at their goal, 0 for those that stay, and for those that leave on
        entering their goal region (aiming ``LEAVE_INSET_M`` inside it) 0 too: they leave
        where the region begins, which the choice does not know."""
        return np.where(self.leaves & ~self._exiting, self.arrival_radius, 0.0)

    def _turned_in(self, vpref: np.ndarray) -> np.ndarray:
        """``vpref`` with each walker near its goal but not heading for it slowed so that it
        can turn in at the comfortable acceleration instead of circling it (the kernel
        ``turned_in`` gives the bound), and each walker that stays at its goal slowed so
        that it stops there at the comfortable deceleration; wider bodies, and those
        leaving on entering their goal region, keep theirs."""
        out = np.empty_like(vpref)
        goals = self._aim_points()
        K.turned_in(vpref, goals, self.positions, self.velocities, self.params["radius"], PERSON_MAX_RADIUS_M,
                    self.comfort_accel, out)
        # one that stays at its goal brakes for it at the comfortable deceleration: no faster
        # than √(2 a d) at d metres off (eq. (3) prices a harder stop above walking on: at a
        # game's 30 steps a second a walker ran a metre past its goal, then paced to and fro)
        stay = ~self.leaves & (self.params["radius"] <= PERSON_MAX_RADIUS_M)
        if stay.any():
            cap = np.sqrt(2.0 * self.comfort_accel * row_norms(goals - self.positions))
            speed = row_norms(out)
            out *= np.where(stay & (speed > cap), cap / np.maximum(speed, 1e-12), 1.0)[:, None]
        # one that leaves on entering its goal region leaves wherever it enters it: slowing
        # to turn in at its aim point held up everyone behind it in an exit door (a room
        # of 100 by a 1 m door emptied 9 % later, 13 % fewer a second through the door)
        out[self._exiting] = vpref[self._exiting]
        return out

    def _aim_points(self) -> np.ndarray:
        """(N, 2) where each agent heads: its goal, but for a walker *packed* round a goal
        point it shares with others (arrived there and staying, at the point or by touching
        the crowd round it, :mod:`crowdmotion.rvo.deadlock`): a point ``PACKED_CREEP_MPS``
        × dt towards its goal, so that it edges in while there is room and otherwise stands.
        Aiming on at the shared point at its walking speed, each of them pressed towards it
        for good and a crowd of 30 swirled round it at about half a metre a second; standing
        wherever it arrived, the crowd settled but as loose as the newcomers had pushed it.
        One that reached a goal point of its own keeps aiming at it: pushed off by someone
        passing, it walks back. Bodies wider than a person keep aiming at the point."""
        packed = self.active & self.packed & ~self.leaves & (self.params["radius"] <= PERSON_MAX_RADIUS_M)
        to = self.goals - self.positions
        d = row_norms(to)
        creep = self.positions + to * (np.minimum(d, PACKED_CREEP_MPS * self.dt) / np.maximum(d, 1e-12))[:, None]
        return np.where(packed[:, None], creep, self.goals)

    def _threatened(self, prims, driven: np.ndarray) -> np.ndarray:
        """(N,) 1.0 for agents within two steps' reach of a moving obstacle or a
        ``driven`` agent (not themselves), else 0."""
        out = np.zeros(self.n_agents)
        if not (self.obstacles.any_moving or driven.any()):
            return out
        r = self.params["radius"] + 2.0 * self.params["max_speed"] * self.dt
        for c, rad, v in zip(prims.circ_c, prims.circ_r, prims.circ_v):
            if v.any():
                near = np.linalg.norm(self.positions - c, axis=1) < r + rad + 2.0 * np.linalg.norm(v) * self.dt
                out[near] = 1.0
        for a, b, v in zip(prims.seg_a, prims.seg_b, prims.seg_v):
            if v.any():
                ab = b - a
                t = np.clip((self.positions - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
                d = np.linalg.norm(self.positions - (a + t[:, None] * ab), axis=1)
                out[d < r + 2.0 * np.linalg.norm(v) * self.dt] = 1.0
        out[driven] = 0.0
        return out

    def _arrivals(self) -> None:
        d = row_norms(self.goals - self.positions)
        now = self.active & ~self.driven & (d <= self.arrival_radius) & np.isnan(self.arrival_time)
        exits = self.active & ~self.driven & self._exiting & np.isnan(self.arrival_time)
        for k in np.unique(self.field_of[exits]):  # those leaving at a region: once their centre is in it
            ids = np.flatnonzero(exits & (self.field_of == k))
            now[ids] = self._goal_regions[k].contains(self.positions[ids]) | (d[ids] <= AIM_REACHED_M)
        stays = ~self.leaves
        if stays.any():  # arrivals that stay: the next arrive by touching them
            arrived = ~np.isnan(self.arrival_time) & (stays | self.active)  # not those that left
            touch = contact_arrivals(self.positions, self.goals, d, self.params["radius"],
                                     self.active & np.isnan(self.arrival_time) & ~now & stays, arrived)
            self.stats["contact_arrivals"] += int(touch.sum())
            now |= touch
            first = now & stays & ~touch  # at the point itself: packed if others share it
            self.packed |= touch | (first & _shared_points(self.goals, stays & (self.active | arrived))
                                    if first.any() else touch)
        self.arrival_time[now] = self.time
        gone = now & self.leaves
        if gone.any():
            self.active &= ~gone
            self.velocities[gone] = 0.0

    def _warn_unreachable(self) -> None:
        """Warn, once, of agents added or sent on since the last step whose goal the
        guidance field (solved by now) says they cannot reach: they would press against
        what cuts them off. Those still waiting to enter are judged once they are in."""
        ids = self._unchecked
        if not len(ids):
            return
        here = self.active[ids]
        self._unchecked = ids[~here & self.waiting[ids]]
        now = ids[here & ~self.driven[ids]]
        if self._fields is None or not len(now):
            return
        cut = now[~self._fields.reachable(self.field_of[now], self.positions[now], window=2)]
        if len(cut):
            who = ", ".join(str(int(i)) for i in cut[:5]) + (f" and {len(cut) - 5} more" if len(cut) > 5 else "")
            warnings.warn(f"agent{'s' if len(cut) > 1 else ''} {who} cannot reach {'their goals' if len(cut) > 1 else 'its goal'}"
                          f": obstacles standing now cut the way on the guidance field ({self._fields.cell:g} m "
                          f"cells); until one is removed, {'they stand' if len(cut) > 1 else 'it stands'} pressed "
                          f"against what blocks it. Simulator.unreachable() says which agents", UserWarning,
                          stacklevel=4)

    def unreachable(self) -> np.ndarray:
        """(N,) active agents the guidance field says cannot reach their goal: no cell of
        the 5 × 5 window round them has a finite distance (all False without a field)."""
        self._ensure_fields()
        if self._fields is None:
            return np.zeros(self.n_agents, dtype=bool)
        self._require(self.field_of[self.active])
        self._complete_partial()
        return self.active & ~self._fields.reachable(self.field_of, self.positions, window=2)

    @property
    def facing(self) -> np.ndarray:
        """(N,) read-only: the way each agent faces, yaw radians about the up axis from +x,
        in [-pi, pi), for a character's root. Updated causally at each step (the offline
        :func:`crowdmotion.facing.facing_from_motion` needs the frames after each one): it
        turns towards the velocity of the step just taken by at most
        ``facing.MAX_TURN_RATE`` (4 rad/s) × ``dt`` while the agent moves faster than
        ``facing.STANDING_FRACTION`` (a quarter) of its ``pref_speed``, and holds while it
        stands or is nudged about at a crawl. An agent faces its goal when added (or when
        it enters, for one that waited); one added on its goal faces +x (0) until it
        first moves, then the way it moves. An agent that left keeps its last facing."""
        out = np.nan_to_num(self._facing, nan=0.0)
        out.flags.writeable = False
        return out

    @property
    def density(self) -> np.ndarray:
        """(N,) the density (agents/m²) each agent sensed ahead of it at the last step
        (0 with ``density_slowing`` off)."""
        return self.density_slowing.density

    @property
    def arrived(self) -> np.ndarray:
        """(N,) whether each agent has reached its goal."""
        return ~np.isnan(self.arrival_time)

    @property
    def present(self) -> np.ndarray:
        """Agents to draw in the current frame: still walking, or arriving this very step."""
        return self.active | (self.arrival_time == self.time)


def warm_up(max_agents: int | None = None) -> int:
    """Compile (on every core, the first time after an install) or load the numba kernels
    a :class:`Simulator`'s steps call, now: call it once before a game's first frame, so
    that no step stops for a compile (6-8 s on one core the first time) or for loading one
    from the cache (up to a second in all). With more than one thread, a crowd of 250
    agents or more steps on the threaded kernels (1000 for the cheaper ones): they are
    compiled too, about 12 s more on one core the first time (from the cache: a few
    hundredths of a second). ``max_agents``, the most agents the game will step at once,
    leaves out those it will never reach. Returns how many kernels are ready."""
    from crowdmotion import _precompile

    ready = _precompile.warm_up("rvo")
    # the kernels of what a scenario run does not do, stepped once in a small scene: a
    # driven player bearing down on someone who has to step aside (escape), with a door
    sim = Simulator(Scene(bounds=([0, 0], [12, 6]), obstacles=[Box([5, 0], [6, 2.5])]), remove_on_arrival=False)
    sim.add_agents([[3.0, 3.0], [8.0, 4.0]], [[3.0, 3.0], [10.0, 4.0]])
    player = sim.add_agents([[1.0, 3.0]], [[1.0, 3.0]], radius=0.3)
    sim.drive(player, [2.0, 0.0])
    door = sim.add_obstacle(Box([5, 4.5], [6, 6]))
    for _ in range(4):
        sim.step()
    sim.remove_obstacle(door)
    sim.step()
    if numba.get_num_threads() > 1:  # the threaded twins, with the argument types the small scene gave
        for kernel in (*vars(K).values(), *vars(_deadlock).values(), *vars(_congestion).values()):
            if isinstance(kernel, ThreadedKernel) and (max_agents is None or max_agents >= kernel.min_items()):
                for signature in kernel.serial.signatures:
                    kernel.threaded.compile(signature)
                    ready += 1
    return ready


def _heading(offset: np.ndarray) -> np.ndarray:
    """(n,) the yaw of each (n, 2) ``offset``, NaN where it is (nearly) zero."""
    far = row_norms(offset) > 1e-9
    return np.where(far, wrap(np.arctan2(offset[:, 1], offset[:, 0])), np.nan)


def _ordinal(i: int) -> str:
    """0 -> "1st", 1 -> "2nd", 10 -> "11th": the i-th (from 0) of a call's values, in words."""
    k = i + 1
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def _nearby_groups(points: np.ndarray, k: int) -> np.ndarray:
    """(P,) a group 0 … (at most k − 1) for each point: k-means by place (k-means++ start,
    a fixed seed, so a call gives the same groups each run), empty groups dropped."""
    from scipy.cluster.vq import kmeans2

    _, labels = kmeans2(points, k, minit="++", seed=np.random.default_rng(0))
    return np.unique(labels, return_inverse=True)[1].ravel()


def _points_region(goal: np.ndarray):
    from crowdmotion.groups import Points

    return Points(np.unique(goal, axis=0))


def _shared_points(goals: np.ndarray, among: np.ndarray) -> np.ndarray:
    """(N,) whether each agent's goal point is also the goal point of another of ``among``."""
    out = np.zeros(len(goals), dtype=bool)
    ids = np.flatnonzero(among)
    if len(ids) > 1:
        _, inverse, counts = np.unique(goals[ids], axis=0, return_inverse=True, return_counts=True)
        out[ids] = counts[inverse.ravel()] > 1
    return out
