"""Smoothed output that keeps the collision guarantee: the smoothing where it stays clear,
the spline through the frames or straight moves where it would not (SPEC §2: smoothed
paths are re-checked)."""

from __future__ import annotations

import warnings

import numpy as np

from crowdmotion.metrics import collision_audit
from crowdmotion.scene import Scene, scene_of
from crowdmotion.trajectories import Trajectories, resample

MAX_ROUNDS = 50
EASE_MIN_S = 0.25  # a step kept straight eases back to the smooth path over at least this long
FIXED_PER_ROUND = 100_000  # overlaps listed (and their steps made straight) per audit round


def resample_checked(traj: Trajectories, fps: float, kind: str, scene: Scene | None,
                     max_speed: np.ndarray | None = None) -> Trajectories:
    """``resample(traj, fps, kind)``, audited in continuous time and fixed per segment.

    Linear resampling at a whole multiple of the run's rate keeps every step, so it is as
    clean as ``traj``; at another rate the frames fall between steps, and a warning says
    if that makes bodies overlap. A spline
    rounds corners and can bring two bodies together, or overshoot past ``max_speed`` (a
    per-agent (N,) array). Every step of an agent's path (a segment between two input
    frames) where that happens falls back, a B-spline's first to the Catmull-Rom spline
    through the frames, and where that too overlaps or outruns, to the straight move; the
    path eases from one into the other and back over a step either side, or ``EASE_MIN_S``
    where the steps are shorter (a cubic blend with level ends, so the path keeps its
    tangent even where the spline does not pass through the frames); the audit runs again
    until it is as clean as the straight moves. The metadata say how many segments fell
    back (``resampled.through_segments`` and ``resampled.straight_segments`` of
    ``resampled.segments``); a warning says so when any keep straight moves.
    """
    linear = resample(traj, fps, "linear")
    if traj.n_frames < 2:
        return linear
    if kind == "linear":
        steps = fps * traj.dt
        if abs(steps - round(steps)) > 1e-9:  # new frames miss the old ones: chords may cut corners
            was, now = collision_audit(traj, scene), collision_audit(linear, scene)
            if now.agent_agent > was.agent_agent or now.agent_obstacle > was.agent_obstacle:
                warnings.warn(f"at {fps:g} fps the frames fall between the run's steps (every {traj.dt:.4g} s) and "
                              f"the straight lines between them overlap {now.agent_agent - was.agent_agent} more "
                              f"times; a rate that is a whole multiple of {1 / traj.dt:.4g} fps keeps every step",
                              stacklevel=2)
        return linear
    through = resample(traj, fps, "catmull-rom") if kind == "b-spline" else None
    return keep_clean(resample(traj, fps, kind), linear, traj, scene, max_speed, kind, through=through)


def at_rate(traj: Trajectories, fps: float, kind: str = "b-spline") -> Trajectories:
    """``traj`` at ``fps`` (along the B-spline of its frames, by default), audited against
    the scene its metadata holds: steps where the spline would bring bodies together or
    past the agent's own fastest step keep straight moves (:func:`resample_checked`; a
    warning says how many). What ``crowdmotion export --fps`` and a USD file give."""
    return resample_checked(traj, float(fps), kind, scene_of(traj), max_speed=np.zeros(traj.n_agents))


def speed_limits(traj: Trajectories, max_speed: np.ndarray) -> np.ndarray:
    """(N,) each agent's speed limit for a smoothing of ``traj``: its ``max_speed``, or its
    own fastest step where that is faster (m/s)."""
    return np.maximum(max_speed, np.linalg.norm(np.diff(traj.positions, axis=0), axis=-1).max(axis=0) / traj.dt)


def keep_clean(smooth: Trajectories, linear: Trajectories, traj: Trajectories, scene: Scene | None,
               max_speed: np.ndarray | None, kind: str, warn: bool = True,
               through: Trajectories | None = None) -> Trajectories:
    """``smooth`` (any smoothing of ``traj`` at ``linear``'s frame rate, ``linear`` its
    straight moves), with every step of an agent's path where ``smooth`` brings bodies
    together or outruns ``max_speed`` falling back to the straight move, eased in and out
    (see :func:`resample_checked`, which calls this). ``kind`` names the smoothing in the
    metadata and the warning (``warn``) that says how many steps fell back.

    ``through`` (optional): a spline through ``traj``'s frames at the same rate
    (Catmull-Rom), tried on a flagged step before its straight move. Two straight moves
    in a row turn at the frame between them within one output frame (a 60 fps file's
    acceleration spikes to tens of m/s² there); a spline through that frame turns over
    the two steps and most such steps stay clear on it."""
    seg = np.minimum(np.floor(smooth.times / traj.dt + 1e-9).astype(int), traj.n_frames - 2)  # segment of a frame
    # each step's fallback level: 0 the smoothing, 1 ``through``, 2 the straight move
    level = np.zeros((traj.n_frames - 1, traj.n_agents), dtype=np.int8)
    top = np.int8(2 if through is None else 1)  # the level a flagged step goes up to first
    flag = np.zeros_like(level, dtype=bool)  # the steps flagged in this round
    limit = None
    if max_speed is not None:  # never faster than the agent's max_speed, or its own fastest step
        limit = speed_limits(traj, max_speed)

    def outrun(tr: Trajectories) -> bool:
        """Flag both ends' segments of every interval that outruns the agent's limit."""
        if limit is None:
            return False
        step = np.linalg.norm(np.diff(tr.positions, axis=0), axis=-1) / tr.dt
        f, i = np.nonzero(step > limit[None, :] + 1e-9)
        flag[seg[f], i] = flag[seg[f + 1], i] = True
        return len(f) > 0

    def escalate() -> None:
        """Each step flagged this round falls back one level (straight at most)."""
        nonlocal level
        level = np.where(flag, np.maximum(level + 1, top), level).clip(0, 2).astype(np.int8)
        flag[:] = False

    outrun(smooth)
    escalate()
    base = collision_audit(linear, scene)

    u = np.clip(smooth.times / traj.dt - seg, 0.0, 1.0)[:, None]  # where each frame lies in its step
    ramp = max(EASE_MIN_S / traj.dt, 1.0)  # steps the blend takes to ease back to the spline
    steps = np.arange(traj.n_frames - 1)[:, None]

    def blend(marked: np.ndarray) -> np.ndarray:
        # 1 on a marked step, easing to 0 over ``ramp`` steps either side (a cubic with
        # level ends: the blend keeps the path's tangent); at the run's own steps (a frame
        # per step) a step's worth of ease is a jump from one path to the other within a
        # frame, which at 60 steps a second outran the speed limit by the paths' gap times
        # 60, flagged the next step, and so on until every step was straight
        left = np.maximum.accumulate(np.where(marked, steps, -np.inf), axis=0)[seg]  # nearest marked at or before
        right = np.minimum.accumulate(np.where(marked, steps, np.inf)[::-1], axis=0)[::-1][seg]  # at or after
        here = seg[:, None]
        gap = np.where(left == here, 0.0, np.minimum(here - left - 1 + u, right - here - u))  # in steps
        x = np.clip(gap / ramp, 0.0, 1.0)
        return 1.0 - x * x * (3.0 - 2.0 * x)

    def mixed() -> tuple[Trajectories, np.ndarray]:
        w = w_straight = blend(level >= 2)
        pos = smooth.positions
        if through is not None:
            w_through = blend(level >= 1)
            pos = pos + w_through[:, :, None] * (through.positions - pos)
            w = w_straight + 2.0 * w_through  # both blends, for telling which frames moved
        pos = pos + w_straight[:, :, None] * (linear.positions - pos)
        own = smooth.has_own_facing  # a method's own facing is kept, not derived again
        return Trajectories(pos, smooth.dt, ids=smooth.ids, group=smooth.group, radius=smooth.radius,
                            active=smooth.active, metadata=dict(smooth.metadata),
                            facing=smooth.facing if own else None,
                            facing_pitch=smooth.facing_pitch if own else None, stage=smooth.stage), w

    # overlaps (agent-agent, agent-obstacle) per frame interval as last audited: a round
    # audits again only the intervals with a frame that moved (each interval is checked on
    # its own), which turns a large run's rounds from minutes into seconds
    found = np.zeros((2, max(smooth.n_frames - 1, 0)), dtype=np.int64)
    w_before = None
    for _ in range(MAX_ROUNDS):
        out, w = mixed()
        dirty = None
        if w_before is not None:
            moved = (w != w_before).any(axis=1)
            dirty = moved[:-1] | moved[1:]
        w_before = w
        rep = collision_audit(out, scene, max_events=FIXED_PER_ROUND, intervals=dirty)
        agent_agent = rep.agent_agent + (0 if dirty is None else int(found[0, ~dirty].sum()))
        agent_obstacle = rep.agent_obstacle + (0 if dirty is None else int(found[1, ~dirty].sum()))
        found[:, slice(None) if dirty is None else dirty] = 0
        for e in rep.events:
            found[0 if e.kind == "agent-agent" else 1, e.frame] += 1
        if len(rep.events) < rep.agent_agent + rep.agent_obstacle:  # not all listed: audit all next round
            w_before = None
        fast = outrun(out)  # easing between two paths adds their gap's change to the speed
        if agent_agent <= base.agent_agent and agent_obstacle <= base.agent_obstacle and not fast:
            break
        for e in rep.events:  # the interval frame -> frame + 1 of each overlap, both agents
            who = (e.a, e.b) if e.kind == "agent-agent" else (e.a,)
            for a in who:
                flag[seg[e.frame], a] = flag[seg[min(e.frame + 1, len(seg) - 1)], a] = True
        escalate()
    else:
        level[:] = 2
        out = mixed()[0]
    n, n_through = int((level == 2).sum()), int((level == 1).sum())
    if n and warn:
        warnings.warn(f"{kind} smoothing would have brought bodies together or past their max speed on "
                      f"{n + n_through} of {level.size} path segments: "
                      + (f"{n_through} follow the spline through the run's frames, {n} " if through is not None
                         else "those ") + "keep straight moves", stacklevel=2)
    out.metadata["resampled"] = {**out.metadata.get("resampled", {}), "kind": kind, "straight_segments": n,
                                 "segments": level.size}
    if through is not None:
        out.metadata["resampled"]["through_segments"] = n_through
    return out


def smoothing_report(traj: Trajectories, kind: str, window_s: float) -> dict:
    """How a method's paths were smoothed, for its summary: ``kind`` ("relaxed", "linear",
    "none"), and for relaxed paths the window (s), where they were relaxed (at ``fps`` or
    at the run's steps) and how many path steps the continuous audit made keep their own
    straight move."""
    out = {"kind": kind}
    if kind == "relaxed":
        relaxed = traj.metadata.get("relaxed", {})
        done = relaxed if "straight_segments" in relaxed else traj.metadata.get("resampled", {})
        out.update({"window_s": window_s, **relaxed,
                    "straight_segments": done.get("straight_segments"), "segments": done.get("segments")})
    return out
