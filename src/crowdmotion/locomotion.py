"""Locomotion: what a character rig needs to walk a path, per agent and frame.

Derived from :class:`~crowdmotion.trajectories.Trajectories` alone (methods do not compute
it), on the frames that are written: an export resampled to 24 fps gets channels of its
24 frames a second. :func:`locomotion` gives, as (T, N) arrays:

``distance``
    metres travelled along the path since the first frame (steps into or out of an
    inactive frame do not count).
``gait_phase``
    where the agent is in its stride, in [0, 1): a *stride* is a full gait cycle of two
    steps; phase 0 is the left foot's heel strike, 0.5 the right's. It advances by
    ``ds / (2 L(v))`` over a step of ``ds`` metres at speed ``v`` while the agent walks or
    runs, so the contact foot does not slide when a clip with stride ``2 L(v)`` is played
    at this phase. Starting and stopping follow what people do (``gait_transitions=False``
    leaves both out): when the agent stops (walk or run to idle or turn), the phase runs on
    at the reference cadence ``f(v_ref) / 2`` until each foot has struck the ground once
    more (at most a stride, about a second: the *closing steps* that bring both feet under
    the standing body), then holds while it stands; when it sets off from standing, the
    phase advances at least at that rate until each foot has struck once (short, quick
    *opening steps*, where the stride model at the low speeds of a start would make the
    first stance cover most of a stride). The step length follows the documented stride
    model (:func:`step_length`):

        L(v) = L_ref · (v / v_ref) ** a,   cadence f(v) = v / L(v) steps/s

    with L_ref = 0.72 m at v_ref = 1.34 m/s and a = 1/2 (step length and cadence each grow
    as the square root of speed). This puts a step of 0.71 m and a cadence of 1.83 steps/s
    at 1.3 m/s, inside the measured 0.7-0.8 m and 1.8-2 steps/s of adults at normal
    walking speed (shared data: empirical-references.md, "Free walking", after Weidmann
    1993's 1.34 m/s), and about 1.1 m at 2.8 steps/s at 3 m/s, a jog. At constant speed
    the phase rate is ``f(v) / 2`` strides per second. Each agent starts at its own
    phase (the fractional part of id × 0.618..., the golden ratio: neighbours' starts are
    spread out) so that a crowd does not set off in step; ``stagger=False`` starts all at 0.
    NaN for agents that are not walkers.
``gait_state``
    int8 codes into :data:`STATES`: ``idle``, ``walk``, ``run``, ``turn`` (turning on the
    spot) for walkers; ``idle`` and ``move`` for cars and drones. From the speed averaged
    over ``speed_window_s`` and the turn rate, each with two thresholds (hysteresis: a
    walker starts walking above ``walk_start`` and stops below ``walk_stop``, ...), then
    any state that lasts less than ``min_state_s`` between two others is taken by the
    state before it: no flicker shorter than that, except at the clip's two ends.
    Inactive frames are idle.
``turn_rate``
    rad/s about the up axis, positive counter-clockwise seen from above (a left turn):
    the time derivative of :attr:`Trajectories.facing`; 0 on inactive frames.
``contact_left``, ``contact_right``
    whether each foot is on the ground: in ``walk`` the left foot is down for phases in
    [0, ``walk_duty``) and the right for [0.5, 0.5 + ``walk_duty``) (a stance of 60 % of
    the cycle, two double-support spells of 10 %: the textbook walking gait, Perry &
    Burnfield, *Gait Analysis*, 2010); in ``run`` with ``run_duty`` (35 %: flight phases
    between the stances); both down while idle, turning or inactive; both False for
    agents that are not walkers.

Which agents walk: :func:`body_kinds` reads the ``bodies`` entry of the metadata (group ->
``walker``, ``car`` or ``drone``; the formation method writes it, naming its car
formations), else 3D runs and PSO swarms are drones and the rest walkers.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from crowdmotion.facing import wrap
from crowdmotion.geometry import finite_number

STATES = ("idle", "walk", "run", "turn", "move")
IDLE, WALK, RUN, TURN, MOVE = range(len(STATES))
KINDS = ("walker", "car", "drone")
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 0.618...: the phase offsets of ids 0, 1, 2, ... spread out evenly


@dataclass(frozen=True)
class LocomotionParams:
    """How gait phase and state are derived (see the module docstring).

    Attributes
    ----------
    step_length_m : float   L_ref, one step (one foot to the other) at ``reference_speed``, m
    reference_speed : float v_ref, m/s (Weidmann's free walking speed)
    stride_exponent : float a in L(v) = L_ref (v / v_ref)^a; 0 keeps a fixed step length
    walk_start : float      m/s: an idle agent walks (or moves) above this speed
    walk_stop : float       m/s: a walking agent stops below this speed
    run_start : float       m/s: a walker runs above this speed (the walk-run transition
                            of about 2 m/s)
    run_stop : float        m/s: a runner walks again below this speed
    turn_start : float      rad/s: a standing walker turns on the spot above this turn rate
    turn_stop : float       rad/s: ... and stands again below this one
    min_state_s : float     s: a state that lasts less than this between two others is
                            taken by the state before it
    speed_window_s : float  s: the state's speed is the path speed averaged over a centred
                            window this long
    walk_duty : float       share of the gait cycle each foot is down while walking
    run_duty : float        share of the gait cycle each foot is down while running
    stagger : bool          start each agent at its own phase (golden-ratio offsets by id)
    gait_transitions : bool closing steps on stopping and opening steps on setting off
                            (see the module docstring)
    """

    step_length_m: float = 0.72
    reference_speed: float = 1.34
    stride_exponent: float = 0.5
    walk_start: float = 0.3
    walk_stop: float = 0.15
    run_start: float = 2.1
    run_stop: float = 1.9
    turn_start: float = 1.0
    turn_stop: float = 0.5
    min_state_s: float = 0.3
    speed_window_s: float = 0.5
    walk_duty: float = 0.6
    run_duty: float = 0.35
    stagger: bool = True
    gait_transitions: bool = True

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in ("stagger", "gait_transitions"):
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"LocomotionParams.{f.name} must be True or False, got {value!r}")
                continue
            if not finite_number(value):
                raise ValueError(f"LocomotionParams.{f.name} must be a finite number, got {value!r}")
            zero_ok = f.name in ("stride_exponent", "walk_stop", "turn_stop", "min_state_s")
            if value < 0 or (value == 0 and not zero_ok):
                raise ValueError(f"LocomotionParams.{f.name} must be {'at least 0' if zero_ok else 'positive'}, "
                                 f"got {value!r}")
        for start, stop in (("walk_start", "walk_stop"), ("run_start", "run_stop"), ("turn_start", "turn_stop")):
            if getattr(self, stop) > getattr(self, start):
                raise ValueError(f"LocomotionParams.{stop} ({getattr(self, stop)!r}) must not exceed {start} "
                                 f"({getattr(self, start)!r}): the state would flicker between them")
        if self.run_stop <= self.walk_start:
            raise ValueError(f"LocomotionParams.run_stop ({self.run_stop!r}) must be above walk_start "
                             f"({self.walk_start!r})")
        for name in ("walk_duty", "run_duty"):
            if not 0 < getattr(self, name) < 1:
                raise ValueError(f"LocomotionParams.{name} must lie between 0 and 1, got {getattr(self, name)!r}")
        if self.stride_exponent >= 1:
            raise ValueError(f"LocomotionParams.stride_exponent must be below 1 (cadence must grow with speed), "
                             f"got {self.stride_exponent!r}")

    def as_dict(self) -> dict:
        """The parameters as plain values (written to each file's metadata)."""
        return asdict(self)


@dataclass
class Locomotion:
    """Locomotion channels of a run, each (T, N) (see the module docstring).

    Attributes
    ----------
    distance : (T, N) float64       metres along the path since the first frame
    gait_phase : (T, N) float64     strides, in [0, 1); NaN for agents that are not walkers
    gait_state : (T, N) int8        codes into :data:`STATES`
    turn_rate : (T, N) float64      rad/s about the up axis, counter-clockwise positive
    contact_left : (T, N) bool      left foot on the ground (False for non-walkers)
    contact_right : (T, N) bool     right foot on the ground (False for non-walkers)
    kind : (N,) object              ``walker``, ``car`` or ``drone``
    params : LocomotionParams       the parameters they were derived with
    """

    distance: np.ndarray
    gait_phase: np.ndarray
    gait_state: np.ndarray
    turn_rate: np.ndarray
    contact_left: np.ndarray
    contact_right: np.ndarray
    kind: np.ndarray
    params: LocomotionParams

    @property
    def walker(self) -> np.ndarray:
        """(N,) bool: agents that walk (have a gait phase and feet)."""
        return self.kind == "walker"

    def metadata(self) -> dict:
        """What a file says about its channels: state names, kinds per group, parameters."""
        return {"states": list(STATES), "params": self.params.as_dict()}


def step_length(speed, params: LocomotionParams | None = None) -> np.ndarray:
    """One step's length at ``speed`` m/s, metres: L(v) = L_ref (v / v_ref)^a."""
    p = params or LocomotionParams()
    v = np.maximum(np.asarray(speed, float), 0.0) / p.reference_speed
    return p.step_length_m * (np.sqrt(v) if p.stride_exponent == 0.5 else v ** p.stride_exponent)


def cadence(speed, params: LocomotionParams | None = None) -> np.ndarray:
    """Steps per second at ``speed`` m/s: v / L(v) (0 at rest). The gait phase advances at
    half this, in strides per second."""
    p = params or LocomotionParams()
    v = np.maximum(np.asarray(speed, float), 0.0)
    return (p.reference_speed / p.step_length_m) * (v / p.reference_speed) ** (1.0 - p.stride_exponent)


def body_kinds(traj, kinds: dict | None = None) -> np.ndarray:
    """(N,) the kind of each agent's body, ``walker``, ``car`` or ``drone``: from ``kinds``
    (group name -> kind), else the ``bodies`` entry of ``traj.metadata`` (the same mapping,
    written by methods that know), else ``drone`` for 3D runs and PSO swarms and
    ``walker`` for the rest."""
    default = "drone" if traj.dim == 3 or traj.metadata.get("method") == "pso" else "walker"
    given = {**(traj.metadata.get("bodies") or {}), **(kinds or {})}
    for group, kind in given.items():
        if kind not in KINDS:
            raise ValueError(f"body kind of group {group!r} must be one of {', '.join(KINDS)}, got {kind!r}")
    names = traj.group.astype(str)
    out = np.full(len(names), default, dtype=object)
    for group, kind in given.items():
        out[names == str(group)] = kind
    return out


def path_speed(positions: np.ndarray, active: np.ndarray, dt: float, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(step lengths (T, N) with 0 at frame 0 and where a step touches an inactive frame,
    path speed (T, N) averaged over a centred window of about ``window_s`` seconds)."""
    t, n, _ = positions.shape
    ds = np.zeros((t, n))
    if t < 2:
        return ds, ds.copy()
    both = active[1:] & active[:-1]
    step = np.diff(positions, axis=0)
    length = np.hypot(step[..., 0], step[..., 1])  # faster than linalg.norm over a last axis of 2 or 3
    if positions.shape[2] == 3:
        length = np.hypot(length, step[..., 2])
    ds[1:] = np.where(both, length, 0.0)  # NaN where inactive: 0
    k = max(1, int(round(window_s / (2 * dt))))
    csum = np.concatenate([np.zeros((1, n)), np.cumsum(ds[1:], axis=0)])  # csum[j]: steps 1..j
    idx = np.arange(t)
    lo, hi = np.maximum(idx - k, 0), np.minimum(idx + k, t - 1)
    speed = (csum[hi] - csum[lo]) / ((hi - lo) * dt)[:, None]
    return ds, speed


def hysteresis(x: np.ndarray, start: float, stop: float) -> np.ndarray:
    """(T, N) bool: on from the frame ``x`` exceeds ``start`` until it falls below
    ``stop`` (each agent's frames before the first decisive one take that one's state;
    an agent whose ``x`` never leaves the band is off)."""
    t = x.shape[0]
    frame = np.arange(t, dtype=np.int32)[:, None]
    on, off = x > start, x < stop
    last_on = np.maximum.accumulate(np.where(on, frame, -1), axis=0)
    last_off = np.maximum.accumulate(np.where(off, frame, -1), axis=0)
    out = last_on > last_off
    # before an agent's first decisive frame: that frame's state
    first_on = np.where(on.any(axis=0), np.argmax(on, axis=0), t)
    first_off = np.where(off.any(axis=0), np.argmax(off, axis=0), t)
    lead = np.maximum(last_on, last_off) < 0
    return np.where(lead, (first_on < first_off)[None, :], out)


def drop_short_states(state: np.ndarray, min_frames: int) -> np.ndarray:
    """(T, N) states in which every run of one state shorter than ``min_frames`` frames,
    other than an agent's first and last, is taken by the state before it."""
    t, n = state.shape
    if min_frames <= 1 or t < 3:
        return state
    flat = np.ascontiguousarray(state.T).ravel()  # agent by agent
    start = np.ones(flat.size, bool)
    start[1:] = flat[1:] != flat[:-1]
    start[::t] = True
    first = np.flatnonzero(start)
    length = np.diff(np.append(first, flat.size))
    at = first % t
    short = (length < min_frames) & (at > 0) & (at + length < t)
    if not short.any():
        return state
    keep = ~np.repeat(short, length)  # an agent's first run is always kept: no fill crosses agents
    src = np.where(keep, np.arange(flat.size), 0)
    np.maximum.accumulate(src, out=src)
    return flat[src].reshape(n, t).T.copy()


def signed_turn_rate(yaw: np.ndarray, dt: float) -> np.ndarray:
    """(T, N) rad/s, d(yaw)/dt by central differences (one-sided at the ends), each
    frame-to-frame turn taken the short way round."""
    t = yaw.shape[0]
    out = np.zeros_like(yaw)
    if t < 2:
        return out
    step = wrap(np.diff(yaw, axis=0)) / dt  # the short way round
    out[0], out[-1] = step[0], step[-1]
    out[1:-1] = 0.5 * (step[1:] + step[:-1])
    return out


def closing_and_opening_steps(advance: np.ndarray, stepping: np.ndarray, active: np.ndarray,
                              rate: float) -> np.ndarray:
    """Add the closing and opening steps to the phase increments ``advance`` (T, N) in
    place (see the module docstring). From each frame an agent stops stepping (and is
    there), the phase runs on by ``rate`` strides a frame until both feet have struck once
    more (the next whole and the next half stride after the phase at the stop), or until
    it steps again; from each frame it sets off from standing, it advances by at least
    ``rate`` a frame until both feet have struck once. Returns (T, N) bool, the frames of
    the closing steps."""
    t, n = advance.shape
    closing = np.zeros((t, n), bool)
    if t < 2:
        return closing
    change = np.zeros((t, n), bool)
    change[1:] = stepping[1:] != stepping[:-1]
    agent_of, frame_of = np.nonzero(change.T)  # agent by agent, in time order
    if not len(agent_of):
        return closing
    # each change's next one, where stepping changes back (t: none)
    next_change = np.r_[frame_of[1:], t]
    next_change[np.r_[agent_of[1:] != agent_of[:-1], True]] = t
    stop = ~stepping[frame_of, agent_of]
    keep = ~stop | active[frame_of, agent_of]  # no closing steps for an agent that is gone
    agent_of, frame_of, next_change, stop = agent_of[keep], frame_of[keep], next_change[keep], stop[keep]
    if not len(agent_of):
        return closing
    ordinal = np.arange(len(agent_of)) - np.searchsorted(agent_of, agent_of)  # 0 for an agent's first event, ...
    phase = np.cumsum(advance, axis=0)  # before any closing or opening step
    carried = np.zeros(n)  # the phase they have added so far, per agent
    for j in range(int(ordinal.max()) + 1):  # the j-th event of every agent that has one, at once
        pick = ordinal == j
        i, k0 = agent_of[pick], frame_of[pick]
        p0 = phase[k0 - 1, i] + carried[i]
        goal = np.maximum(np.floor(p0) + 1.0, np.floor(p0 - 0.5) + 1.5)  # left strikes at whole strides, right at halves
        frames = np.ceil((goal - p0) / rate - 1e-9).astype(np.int64)  # at least `rate` a frame: no more than these
        length = np.minimum(k0 + frames, next_change[pick]) - k0
        gap = np.repeat(goal - p0, length)
        s = np.arange(length.sum()) - np.repeat(np.cumsum(length) - length, length)  # frames into each window
        rows, cols = np.repeat(k0, length) + s, np.repeat(i, length)
        closes = np.repeat(stop[pick], length)
        before = advance[rows, cols]
        boosted = np.maximum(before, rate)
        run = np.cumsum(boosted)
        run -= np.repeat(np.r_[0.0, run][np.cumsum(length) - length], length)  # summed within each window
        # closing: exactly `rate` a frame up to the goal; opening: at least `rate` while short of it
        added = np.where(closes, np.minimum((s + 1) * rate, gap) - np.minimum(s * rate, gap),
                         np.where(run - boosted < gap, boosted, before))
        advance[rows, cols] = np.where(closes, before + added, added)
        closing[rows[closes], cols[closes]] = True
        extra = np.where(closes, added, added - before)
        np.add.at(carried, cols, extra)
    return closing


def locomotion(traj, params: LocomotionParams | None = None, kinds: dict | None = None) -> Locomotion:
    """Locomotion channels of ``traj`` on its own frames (see the module docstring).

    Parameters
    ----------
    traj : Trajectories
        The frames to derive them on (resample first to get them at another rate).
    params : LocomotionParams, optional
        Stride model, thresholds and duty factors; the documented defaults when None.
    kinds : dict, optional
        Group name -> ``walker``, ``car`` or ``drone``, over :func:`body_kinds`' choice.

    Returns
    -------
    Locomotion

    Raises
    ------
    ValueError
        An active agent at a NaN or infinite position (naming agent, frame and value), a
        body kind that is none of :data:`KINDS`.
    """
    p = params or LocomotionParams()
    if not isinstance(p, LocomotionParams):
        raise TypeError(f"params must be a LocomotionParams, got {type(p).__name__}")
    from crowdmotion.geometry import require_finite_agents

    t, n, _ = traj.positions.shape
    dt = traj.dt
    active = traj.active_mask
    require_finite_agents({"Trajectories.positions": traj.positions}, active, ids=traj.ids)
    kind = body_kinds(traj, kinds)
    walker = kind == "walker"

    ds, speed = path_speed(traj.positions, active, dt, p.speed_window_s)
    distance = np.cumsum(ds, axis=0)
    rate = signed_turn_rate(traj.facing, dt)
    rate[~active | ~np.isfinite(rate)] = 0.0  # an agent that is not there does not turn

    moving = hysteresis(speed, p.walk_start, p.walk_stop)
    moving &= active
    running = moving & hysteresis(speed, p.run_start, p.run_stop)
    turning = ~moving & hysteresis(np.abs(rate), p.turn_start, p.turn_stop) & active
    i8 = np.int8
    walker_state = moving.view(i8) * i8(WALK) + running.view(i8) * i8(RUN - WALK) + turning.view(i8) * i8(TURN)
    if walker.all():
        state = walker_state
    else:
        state = np.where(walker[None, :], walker_state, moving.view(i8) * i8(MOVE)).astype(i8)
    state = drop_short_states(state, math.ceil(p.min_state_s / dt - 1e-9))

    stepping = (state == WALK) | (state == RUN)
    # a step's length at the speed of its two frames (never below walk_stop's: no blow-up at a crawl)
    v_step = np.maximum(speed, max(p.walk_stop, 1e-3))
    v_step[1:] += v_step[:-1]
    v_step[1:] *= 0.5
    advance = ds / (2.0 * step_length(v_step, p))
    advance *= stepping
    if p.stagger:
        advance[0] += (traj.ids.astype(np.float64) * GOLDEN) % 1.0
    closing = np.zeros((t, n), bool)
    if p.gait_transitions:
        closing = closing_and_opening_steps(advance, stepping, active & walker[None, :],
                                            0.5 * float(cadence(p.reference_speed, p)) * dt)
    phase = np.cumsum(advance, axis=0)
    np.mod(phase, 1.0, out=phase)

    duty = np.where(state == RUN, p.run_duty, p.walk_duty)
    feet_move = stepping | closing
    left = ~feet_move | (phase < duty)
    right = ~feet_move | ((phase - 0.5) % 1.0 < duty)
    if not walker.all():
        phase[:, ~walker] = np.nan
        left &= walker[None, :]
        right &= walker[None, :]
    return Locomotion(distance, phase, state, rate, left, right, kind, p)
