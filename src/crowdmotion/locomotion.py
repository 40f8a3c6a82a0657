"""Locomotion: what a character rig needs to walk a path, per agent and frame.

Derived from :class:`~crowdmotion.trajectories.Trajectories` alone (methods do not compute
it), on the frames that are written: an export resampled to 24 fps gets channels of its
24 frames a second. What happens between two frames is timed within the step: a state
changes at the instant its speed or turn rate crosses the threshold (taken linearly
between the two frames), the speed window is as long in seconds at any rate, and the
closing and opening steps start at that instant and end where the last foot strikes;
so exports of one run at different rates agree at the instants they share, to what
their resampled paths differ by. :func:`locomotion` gives, as (T, N) arrays:

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
    phase advances at least at that rate until each foot has struck once after it set
    off, the strike it stood on not counted (short, quick *opening steps*, where the
    stride model at the low speeds of a start would make the first stance cover most of
    a stride). The step length follows the documented stride model (:func:`step_length`):

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
    any state that lasts less than ``min_state_s`` (from the instant it begins to the
    instant the next begins) between two others is taken by the state before it: no
    flicker shorter than that, except at the clip's two ends. Inactive frames are idle.
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
STRIKE_TOLERANCE = 1e-6  # strides: a phase this close below a heel strike stands on it


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
    path speed (T, N) averaged over a centred window of ``window_s`` seconds (at least a
    frame either side; shorter at the ends), the distance at the window's ends taken
    linearly between frames: the same speed at the same instant at any frame rate)."""
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
    half = max(1.0, window_s / (2 * dt))  # frames either side
    whole = int(half)
    part = half - whole  # the window's ends lie `part` of a step past frame k +- whole
    csum = np.cumsum(ds, axis=0)  # csum[j]: steps 1..j, the distance at frame j
    # the distance at k + half (interpolated within its step; the last frame's past the end) ...
    speed = np.empty((t, n))
    inside = min(max(int(math.floor(t - 1 - half + 1e-9)) + 1, 0), t)  # the frames whose k + half <= t - 1
    speed[:inside] = csum[whole:whole + inside]
    if part > 1e-9:
        speed[:inside] += part * ds[whole + 1:whole + 1 + inside]
    speed[inside:] = csum[-1]
    # ... less that at k - half (0 before the first frame)
    if part > 1e-9:
        inside = whole + 1  # the first frame whose k - half >= 0
        if inside < t:
            speed[inside:] -= csum[:t - inside]
            speed[inside:] -= (1.0 - part) * ds[1:t - inside + 1]
    elif whole < t:
        speed[whole:] -= csum[:t - whole]
    idx = np.arange(t, dtype=np.float64)
    lo, hi = np.maximum(idx - half, 0.0), np.minimum(idx + half, t - 1.0)
    speed /= ((hi - lo) * dt)[:, None]
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


def change_leads(state: np.ndarray, speed: np.ndarray, turn: np.ndarray, params: LocomotionParams) -> np.ndarray:
    """(T, N) float: where each agent's state changes at frame k, the share of the step
    from frame k-1 to k that passes before it changes: the instant the value behind the
    change (the speed for idle/turn <-> walk/run/move at ``walk_start`` or ``walk_stop``,
    and for walk <-> run at ``run_start`` or ``run_stop``; the absolute turn rate for idle
    <-> turn) crosses its threshold, taken linearly between the two frames. 0 elsewhere
    and where no such crossing lies between them (a change the active mask made). Taken
    before :func:`drop_short_states`: a change it leaves is one of these, at the instant
    the state it changes to began."""
    t, n = state.shape
    lead = np.zeros((t, n))
    if t < 2:
        return lead
    k, i = np.nonzero(state[1:] != state[:-1])
    if not len(k):
        return lead
    k += 1
    s0, s1 = state[k - 1, i], state[k, i]
    goes = np.array([s in (WALK, RUN, MOVE) for s in range(len(STATES))])
    moving_flip = goes[s0] != goes[s1]
    running_flip = ~moving_flip & ((s0 == RUN) | (s1 == RUN))
    turning = ~moving_flip & ~running_flip
    up = np.where(moving_flip, goes[s1], np.where(running_flip, s1 == RUN, s1 == TURN))
    start = np.where(moving_flip, params.walk_start, np.where(running_flip, params.run_start, params.turn_start))
    stop = np.where(moving_flip, params.walk_stop, np.where(running_flip, params.run_stop, params.turn_stop))
    threshold = np.where(up, start, stop)
    x0 = np.where(turning, np.abs(turn[k - 1, i]), speed[k - 1, i])
    x1 = np.where(turning, np.abs(turn[k, i]), speed[k, i])
    rise = x1 - x0
    with np.errstate(divide="ignore", invalid="ignore"):
        share = (threshold - x0) / rise
    crossed = np.isfinite(share) & (share >= 0.0) & (share <= 1.0) & np.where(up, rise > 0, rise < 0)
    lead[k, i] = np.where(crossed, share, 0.0)
    return lead


def drop_short_states(state: np.ndarray, min_frames: float, lead: np.ndarray | None = None) -> np.ndarray:
    """(T, N) states in which every run of one state that lasts less than ``min_frames``
    frames, other than an agent's first and last, is taken by the state before it. A run
    lasts from the instant it begins to the instant the next begins: a change at frame k
    comes ``lead[k]`` of a step after frame k-1 (:func:`change_leads`; at frame k-1 when
    None)."""
    t, n = state.shape
    if min_frames <= (0 if lead is not None else 1) or t < 3:  # (a run of whole frames lasts at least one)
        return state
    flat = np.ascontiguousarray(state.T).ravel()  # agent by agent
    start = np.ones(flat.size, bool)
    start[1:] = flat[1:] != flat[:-1]
    start[::t] = True
    first = np.flatnonzero(start)
    length = np.diff(np.append(first, flat.size))
    at = first % t
    inner = (at > 0) & (at + length < t)
    lasts = length.astype(np.float64)
    if lead is not None and inner.any():
        begins = lead[at, first // t]  # 0 at an agent's first frame: never inner
        ends = np.append(begins[1:], 0.0)  # the next run's lead (an inner run has a next one)
        lasts += ends - begins
    short = (lasts < min_frames - 1e-9) & inner
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


def changes_of(flags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(agents, frames) where the (T, N) ``flags`` change from the frame before, agent by
    agent in time order."""
    agent_of, frame_of = np.nonzero((flags[1:] != flags[:-1]).T)
    return agent_of, frame_of + 1


def closing_and_opening_steps(advance: np.ndarray, stepping: np.ndarray, active: np.ndarray,
                              rate: float, lead: np.ndarray | None = None,
                              changes: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Add the closing and opening steps to the phase increments ``advance`` (T, N) in
    place (see the module docstring). An agent stops or sets off where ``stepping``
    changes, at frame k, ``lead[k]`` of a step after frame k-1 (at frame k-1 when None;
    ``advance`` there holds the natural advance of the share of the step it steps). From
    the instant it stops (and is there), the phase runs on at ``rate`` strides a step
    until both feet have struck once more (the next whole and the next half stride after
    the phase at the stop), or until it steps again; from the instant it sets off, it
    advances at least at ``rate`` until both feet have struck once, and then at its own
    rate again, within the step it gets there. ``changes``: :func:`changes_of` ``stepping``
    when that is at hand. Returns (T, N) bool, the frames inside the closing steps (the
    last foot to strike not yet down)."""
    t, n = advance.shape
    closing = np.zeros((t, n), bool)
    if t < 2:
        return closing
    agent_of, frame_of = changes_of(stepping) if changes is None else changes
    if not len(agent_of):
        return closing
    # each change's next one, where stepping changes back (t: none)
    next_change = np.r_[frame_of[1:], t]
    next_change[np.r_[agent_of[1:] != agent_of[:-1], True]] = t
    shares = np.zeros(len(agent_of)) if lead is None else lead[frame_of, agent_of]
    next_share = np.r_[shares[1:], 0.0]  # the share of its step before the next change
    stop = ~stepping[frame_of, agent_of]
    keep = ~stop | active[frame_of, agent_of]  # no closing steps for an agent that is gone
    agent_of, frame_of, next_change, stop = agent_of[keep], frame_of[keep], next_change[keep], stop[keep]
    shares, next_share = shares[keep], next_share[keep]
    if not len(agent_of):
        return closing
    natural = advance[frame_of, agent_of]  # the natural advance of each change's own step
    ordinal = np.arange(len(agent_of)) - np.searchsorted(agent_of, agent_of)  # 0 for an agent's first event, ...
    phase = np.cumsum(advance, axis=0)  # before any closing or opening step
    carried = np.zeros(n)  # the phase they have added so far, per agent
    for j in range(int(ordinal.max()) + 1):  # the j-th event of every agent that has one, at once
        pick = ordinal == j
        i, k0, k1, closes0 = agent_of[pick], frame_of[pick], next_change[pick], stop[pick]
        # the phase at the instant of the change: a stop comes after its step's stepping share
        p0 = phase[k0 - 1 + closes0, i] + carried[i]
        # left strikes at whole strides, right at halves; a strike the phase stands on (to rounding: where
        # closing steps left it) has been made
        q = p0 + STRIKE_TOLERANCE
        goal = np.maximum(np.floor(q) + 1.0, np.floor(q - 0.5) + 1.5)
        # the share of each step the window's motion takes: all of it inside, the first step's after the
        # change, the next change's step before that change
        first = 1.0 - shares[pick]
        steps = np.maximum(np.ceil((goal - p0) / rate - first - 1e-9), 0).astype(np.int64)  # then whole steps
        # the window: from the change's frame to the one it gets there in, or the next change's, or the last
        length = np.minimum(np.minimum(k0 + steps, k1), t - 1) - k0 + 1
        offsets = np.cumsum(length) - length
        gap = np.repeat(goal - p0, length)
        s = np.arange(length.sum()) - np.repeat(offsets, length)  # frames into each window
        rows, cols = np.repeat(k0, length) + s, np.repeat(i, length)
        closes = np.repeat(closes0, length)
        share = np.where(rows == np.repeat(k1, length), np.repeat(next_share[pick], length), 1.0)
        share[offsets] = first
        before = advance[rows, cols]
        before[offsets] = natural[pick]
        boosted = share * rate
        np.maximum(boosted, before, out=boosted, where=~closes)
        done = np.cumsum(boosted)
        done -= np.repeat(np.r_[0.0, done][offsets], length)  # summed within each window, to each step's end
        prior = done - boosted  # ... up to its beginning
        # closing: exactly `rate` a step up to the goal; opening: at least `rate` up to the goal, then the
        # natural advance for the rest of the step it gets there in
        reach = np.clip(gap - prior, 0.0, None)
        within = np.divide(reach, boosted, out=np.ones_like(reach), where=boosted > 0)
        added = np.where(closes, np.minimum(done, gap) - np.minimum(prior, gap),
                         np.where(done <= gap, boosted,
                                  np.where(prior < gap, reach + before * (1.0 - np.minimum(within, 1.0)), before)))
        extra = np.where(closes, added, added - before)
        advance[rows, cols] += extra
        moving = closes & (done < gap - STRIKE_TOLERANCE)  # at the frame, short of the last strike: a foot is up
        closing[rows[moving], cols[moving]] = True
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
    lead = change_leads(state, speed, rate, p)
    state = drop_short_states(state, p.min_state_s / dt, lead)

    stepping = (state == WALK) | (state == RUN)
    # a step's length at the speed of its two frames (never below walk_stop's: no blow-up at a crawl)
    v_step = np.maximum(speed, max(p.walk_stop, 1e-3))
    v_step[1:] += v_step[:-1]
    v_step[1:] *= 0.5
    advance = ds / (2.0 * step_length(v_step, p))
    # where it sets off or stops, the share of the step it steps: after or before the change
    changes = i, k = changes_of(stepping)
    natural = advance[k, i] * np.where(stepping[k, i], 1.0 - lead[k, i], lead[k, i])
    advance *= stepping
    advance[k, i] = natural
    if p.stagger:
        advance[0] += (traj.ids.astype(np.float64) * GOLDEN) % 1.0
    closing = np.zeros((t, n), bool)
    if p.gait_transitions:
        closing = closing_and_opening_steps(advance, stepping, active & walker[None, :],
                                            0.5 * float(cadence(p.reference_speed, p)) * dt, lead, changes)
    phase = np.cumsum(advance, axis=0)
    phase -= np.floor(phase)  # mod 1 (the same numbers: the phase is never negative), in less time

    duty = np.where(state == RUN, p.run_duty, p.walk_duty)
    feet_move = stepping | closing
    left = ~feet_move | (phase < duty)
    behind = phase - 0.5
    np.add(behind, 1.0, out=behind, where=behind < 0.0)  # (phase - 0.5) mod 1: the right foot's phase
    right = ~feet_move | (behind < duty)
    if not walker.all():
        phase[:, ~walker] = np.nan
        left &= walker[None, :]
        right &= walker[None, :]
    return Locomotion(distance, phase, state, rate, left, right, kind, p)
