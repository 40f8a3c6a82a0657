"""Trajectories: the one output type every method returns and every exporter reads."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np


@dataclass
class Trajectories:
    """Agent positions sampled at a fixed time step.

    Attributes
    ----------
    positions : (T, N, D) float64   world positions, metres
    dt : float                      seconds between frames
    ids : (N,) int64                agent ids
    group : (N,) str                group name of each agent
    radius : (N,) float64           body radius of each agent, metres
    active : (T, N) bool or None    False once an agent has arrived/despawned
    metadata : dict                 method, parameters, seed, scene, library version, ...
    facing : (T, N) float64         the way each agent faces, yaw radians about the up axis
                                    from +x: given by the method (a car's pair angle, a
                                    soldier's formation heading) or, when None, derived from
                                    the motion by :func:`crowdmotion.facing.facing_from_motion`
                                    (smooth, bounded turn rate, held while standing)
    facing_pitch : (T, N) float64   3D: the facing's angle above the x-y plane (derived
                                    from the motion when None); zeros in 2D
    stage : (T, N) int16 or None    the stage of its route each agent is in per frame (its
                                    stage id, :mod:`crowdmotion.stages`; -1 off route or
                                    not in the scene); None when no agent follows a route
    """

    positions: np.ndarray
    dt: float
    ids: np.ndarray | None = None
    group: np.ndarray | None = None
    radius: np.ndarray | None = None
    active: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    facing: np.ndarray | None = None
    facing_pitch: np.ndarray | None = None
    stage: np.ndarray | None = None

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=np.float64)
        if p.ndim != 3 or p.shape[2] not in (2, 3):
            raise ValueError(f"Trajectories.positions must have shape (T, N, 2 or 3), got {p.shape}")
        self.positions = p
        t, n, _ = p.shape
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"Trajectories.dt must be a positive number of seconds, got {self.dt!r}")
        self.dt = float(self.dt)
        self.ids = np.arange(n, dtype=np.int64) if self.ids is None else np.asarray(self.ids, dtype=np.int64)
        self.group = (
            np.full(n, "agents", dtype=object) if self.group is None else np.asarray(self.group, dtype=object)
        )
        r = 0.0 if self.radius is None else self.radius
        self.radius = np.broadcast_to(np.asarray(r, dtype=np.float64), (n,)).copy()
        for name, arr in (("ids", self.ids), ("group", self.group), ("radius", self.radius)):
            if arr.shape != (n,):
                raise ValueError(f"Trajectories.{name} must have shape ({n},), got {arr.shape}")
        if self.active is not None:
            self.active = np.asarray(self.active, dtype=bool)
            if self.active.shape != (t, n):
                raise ValueError(f"Trajectories.active must have shape ({t}, {n}), got {self.active.shape}")
        if self.stage is not None:
            st = np.asarray(self.stage)
            if st.shape != (t, n) or (st.size and not np.issubdtype(st.dtype, np.integer)):
                raise ValueError(f"Trajectories.stage must be ({t}, {n}) integers, got {st.dtype} {st.shape}")
            if st.size and (st.min() < -1 or st.max() > np.iinfo(np.int16).max):
                raise ValueError("Trajectories.stage must hold stage ids >= 0, or -1 off route")
            self.stage = st.astype(np.int16)
        for name in ("facing", "facing_pitch"):  # a method's own, checked here; else derived on first use
            arr = getattr(self, "_" + name)
            if arr is None:
                continue
            arr = np.asarray(arr, dtype=np.float64)
            if arr.shape != (t, n):
                raise ValueError(f"Trajectories.{name} must have shape ({t}, {n}), got {arr.shape}")
            if not np.isfinite(arr).all():
                raise ValueError(f"Trajectories.{name} must be finite angles in radians; it holds NaN or inf")
            setattr(self, "_" + name, arr)
        if self.dim == 2:
            self._facing_pitch = None  # level: zeros on first use

    def _derive_facing(self) -> None:
        """Fill whichever of facing / facing_pitch the method did not give, from the motion
        (done once, when first read: intermediate Trajectories never pay for it)."""
        from crowdmotion.facing import facing_from_motion

        if self._facing is None or (self.dim == 3 and self._facing_pitch is None):
            yaw, pitch = facing_from_motion(self.positions, self.dt, self.active)
            self._facing = yaw if self._facing is None else self._facing
            self._facing_pitch = pitch if self._facing_pitch is None else self._facing_pitch
        if self._facing_pitch is None:  # 2D
            self._facing_pitch = np.zeros(self.positions.shape[:2])

    @property
    def has_own_facing(self) -> bool:
        """Whether the method gave its own facing (``metadata["facing"]`` says how); a
        derived one is derived again from resampled motion rather than interpolated."""
        return bool(self.metadata.get("facing"))

    # ---- shape -------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    @property
    def n_agents(self) -> int:
        return self.positions.shape[1]

    @property
    def dim(self) -> int:
        return self.positions.shape[2]

    @property
    def fps(self) -> float:
        """Frames per second, 1 / dt: a whole number when it is one to 1e-6 (24.0, not
        23.999999999999957), so files say 24 fps."""
        rate = 1.0 / self.dt
        return float(round(rate)) if abs(rate - round(rate)) < 1e-6 * rate else rate

    @property
    def times(self) -> np.ndarray:
        """Time of each frame, seconds."""
        return np.arange(self.n_frames) * self.dt

    @property
    def active_mask(self) -> np.ndarray:
        """(T, N) bool, all True when no mask was given."""
        if self.active is None:
            return np.ones(self.positions.shape[:2], dtype=bool)
        return self.active

    def jump_steps(self) -> list[tuple[int, int]]:
        """``(f, agent)`` for each jump in ``metadata["jumps"]`` (``[time, agent]`` pairs: an
        agent a live run's ``place()`` moved): it jumps in the step from frame ``f`` to
        ``f + 1``, which is not walked. Pairs outside the frames or the agents are left out."""
        out = []
        for t, i in self.metadata.get("jumps") or []:
            f = int(np.floor(float(t) / self.dt + 1e-9))  # the frame the jump leaves from
            if 0 <= f < self.n_frames - 1 and 0 <= int(i) < self.n_agents:
                out.append((f, int(i)))
        return out

    # ---- derived -----------------------------------------------------------------
    @property
    def velocity(self) -> np.ndarray:
        """(T, N, D) velocity over the step that starts at each frame (last repeats)."""
        v = np.zeros_like(self.positions)
        if self.n_frames > 1:
            v[:-1] = np.diff(self.positions, axis=0) / self.dt
            v[-1] = v[-2]
        return v

    @property
    def speed(self) -> np.ndarray:
        """(T, N) speed, metres per second."""
        return np.linalg.norm(self.velocity, axis=-1)

    @property
    def heading(self) -> np.ndarray:
        """(T, N) heading angle in the x-y plane, radians; held while an agent stands."""
        v = self.velocity
        ang = np.arctan2(v[..., 1], v[..., 0])
        moving = np.linalg.norm(v[..., :2], axis=-1) > 1e-12
        out = np.zeros_like(ang)
        for t in range(self.n_frames):  # hold last heading while standing
            prev = out[t - 1] if t else np.zeros(self.n_agents)
            out[t] = np.where(moving[t], ang[t], prev)
        return out

    @property
    def pitch(self) -> np.ndarray:
        """(T, N) climb angle of a 3D run, radians above the x-y plane (0 in 2D, and level
        while an agent hovers)."""
        if self.dim == 2:
            return np.zeros(self.positions.shape[:2])
        v = self.velocity
        return np.arctan2(v[..., 2], np.linalg.norm(v[..., :2], axis=-1))

    def locomotion(self, params=None):
        """The locomotion channels on these frames
        (:func:`crowdmotion.locomotion.locomotion` with ``params``, a
        :class:`~crowdmotion.locomotion.LocomotionParams`, the defaults when None), derived
        once and kept: every file a run writes and its player share them. They are derived
        again if the positions, active mask, facing, time step or the metadata's body kinds
        are replaced (not if an array is changed in place)."""
        from crowdmotion.locomotion import LocomotionParams, locomotion

        params = LocomotionParams() if params is None else params
        meta = self.metadata
        key = (params, id(self.positions), id(self.active), id(self.facing), self.dt,
               repr(meta.get("bodies")), meta.get("method"))
        cache = self.__dict__.get("_locomotion")
        if cache is None or cache[0] != key:
            cache = (key, locomotion(self, params))
            self.__dict__["_locomotion"] = cache
        return cache[1]

    def select(self, agents=None, frames=None) -> "Trajectories":
        """A sub-set of agents and/or frames (indices or boolean masks)."""
        a = slice(None) if agents is None else agents
        f = slice(None) if frames is None else frames
        return Trajectories(
            positions=self.positions[f][:, a],
            dt=self.dt,
            ids=self.ids[a],
            group=self.group[a],
            radius=self.radius[a],
            active=None if self.active is None else self.active[f][:, a],
            metadata=dict(self.metadata),
            facing=self.facing[f][:, a],
            facing_pitch=self.facing_pitch[f][:, a],
            stage=None if self.stage is None else self.stage[f][:, a],
        )

    # ---- files -------------------------------------------------------------------
    def save(self, path: str | Path, **options) -> Path:
        """Write to ``.parquet``, ``.csv`` (long form), ``.sqlite`` (JuPedSim) or ``.usd*``,
        atomically, with the locomotion channels; ``options`` go to the writer (see
        :func:`crowdmotion.io.write_trajectories`). Returns the path."""
        from crowdmotion.io import write_trajectories

        return write_trajectories(self, path, **options)

    @classmethod
    def load(cls, path: str | Path) -> "Trajectories":
        """Read a file written by :meth:`save`; a ValueError naming the file if it has no
        frames, an active agent at a NaN/inf position or a bad radius."""
        from crowdmotion.io import read_trajectories

        return read_trajectories(path)


RESAMPLE_KINDS = ("linear", "catmull-rom", "b-spline")


def held_absent(frames: np.ndarray, present: np.ndarray) -> np.ndarray:
    """``frames`` (T, N, dim) with every agent's rows where ``present`` (T, N) says it is
    not in the scene held where it stands when next in it (before it came in) or where it
    last stood (after it left, or between two stays): where a simulator kept a waiting
    agent (its entry point, drawn again while it waited) is no place it was, and a spline
    through those rows turned it and slid it about before it appeared. In place; returned."""
    seen = present.any(axis=0)
    if not seen.any() or present[:, seen].all():
        return frames
    t = np.arange(len(present))[:, None]
    last = np.maximum.accumulate(np.where(present, t, -1), axis=0)  # the last frame it was in, at or before
    nxt = np.minimum.accumulate(np.where(present, t, len(present))[::-1], axis=0)[::-1]  # the next, at or after
    src = np.where(last >= 0, last, nxt)
    cols = np.flatnonzero(seen)
    frames[:, cols] = frames[src[:, cols], cols]
    return frames


def walked_on(positions: np.ndarray, active: np.ndarray, frames: int = 2) -> np.ndarray:
    """``positions`` (T, N, dim) with the ``frames`` absent rows after each stay in the
    scene carrying on its last step, and those before it its first step backwards: a
    spline's control points there, so that a walker leaves (and enters) at its pace. Held
    where it left, the spline slowed every leaver over its last frames (1.2 to 0.7 m/s at
    24 fps) and read it standing as it vanished. The rows stay absent; a copy."""
    out = np.array(positions, float, copy=True)
    t = len(out)
    if t < 2:
        return out
    edge = np.diff(np.pad(active.astype(np.int8), ((1, 1), (0, 0))), axis=0)  # +1 where a stay starts, -1 after it
    for f, i in zip(*np.nonzero(edge == -1)):  # f: the first frame after a stay
        last = f - 1
        step = out[last, i] - out[last - 1, i] if last >= 1 and active[last - 1, i] else 0.0
        for d in range(1, frames + 1):
            if last + d < t and not active[last + d, i]:
                out[last + d, i] = out[last, i] + d * step
    for f, i in zip(*np.nonzero(edge == 1)):  # f: a stay's first frame
        step = out[f + 1, i] - out[f, i] if f + 1 < t and active[f + 1, i] else 0.0
        for d in range(1, frames + 1):
            if f - d >= 0 and not active[f - d, i]:
                out[f - d, i] = out[f, i] - d * step
    return out


def held_stages(stage: np.ndarray, times: np.ndarray, step_dt: float, active: np.ndarray) -> np.ndarray:
    """(T', N) int16 stages at new frame ``times`` (s) of a run stepped every ``step_dt``
    s: each new frame holds the stage of the step it ends in, -1 where ``active`` says
    the agent is not in the scene."""
    held = np.minimum(np.ceil(times / step_dt - 1e-9).astype(int), len(stage) - 1)
    return np.where(active, stage[held], -1).astype(np.int16)


def resample(traj: Trajectories, fps: float, kind: str = "linear") -> Trajectories:
    """Resample one-frame-per-step trajectories to ``fps`` frames per second (any method).

    ``"linear"`` keeps the straight moves (and so their collision-freedom);
    ``"catmull-rom"`` passes a uniform Catmull-Rom spline through the cell centres, which
    rounds corners; ``"b-spline"`` follows the uniform cubic B-spline whose control points
    are the frames (the first and last frames reflected, so it starts and ends on them):
    its acceleration is continuous and, at each frame, the step's own change of velocity,
    so a character bound to it neither twitches at the frames nor overshoots; it passes
    within a sixth of a step's change of velocity × dt of each frame. Both splines must
    be re-audited (:func:`crowdmotion.smoothing.resample_checked` does so). Frames keep
    the positions of every step when ``fps · dt`` is a whole number, except with
    ``"b-spline"``.
    """
    if kind not in RESAMPLE_KINDS:
        raise ValueError(f"resampling must be one of {', '.join(RESAMPLE_KINDS)}, got {kind!r}")
    t_old = traj.times
    n_new = int(np.floor(t_old[-1] * fps + 1e-9)) + 1
    t_new = np.arange(n_new) / fps
    u = t_new / traj.dt  # position in steps
    k = np.minimum(np.floor(u).astype(int), traj.n_frames - 2) if traj.n_frames > 1 else np.zeros(n_new, int)
    s = (u - k)[:, None, None]
    through = traj.positions if kind == "linear" or traj.active is None else walked_on(traj.positions, traj.active)
    pos = _along(through, u, kind)
    # an agent that jumps (``metadata["jumps"]``: placed elsewhere in a live run) is resampled
    # piece by piece between its jumps, each piece ending where it was; the jump keeps its
    # place: it leaves from the last new frame before the step it was made in ends
    jumps = []
    pieces: dict[int, list[int]] = {}
    for f, i in traj.jump_steps():
        pieces.setdefault(i, []).append(f)
        jumps.append([float(t_new[np.flatnonzero(u < f + 1 - 1e-9)[-1]]), i])
    for i, fs in pieces.items():
        bounds = [0] + sorted(f + 1 for f in set(fs)) + [traj.n_frames]
        for a, b in zip(bounds[:-1], bounds[1:]):  # frames a .. b-1, one piece
            sel = (u >= a - 1e-9) & (u < b - 1e-9) if b < traj.n_frames else u >= a - 1e-9
            pos[sel, i] = _along(traj.positions[a:b, i:i + 1], np.clip(u[sel] - a, 0.0, b - 1 - a), kind)[:, 0]
    active = stage = None
    held = np.minimum(np.ceil(u - 1e-9).astype(int), traj.n_frames - 1)  # the frame each new one ends in
    if traj.active is not None:  # in the scene at the frames on both sides: from the frame it entered in,
        since = np.minimum(np.floor(u + 1e-9).astype(int), traj.n_frames - 1)  # until the last it was in
        active = traj.active[held] & traj.active[since]
        # rows out of the scene stand still where it entered or left: a spline through the
        # held rows still moved an agent for a frame or two after it left (0.4 m/s at 24 fps)
        pos = held_absent(pos, active)
    if traj.stage is not None:  # (-1 where it is not in the scene)
        stage = traj.stage[held] if active is None else np.where(active, traj.stage[held], -1).astype(traj.stage.dtype)
    meta = {**traj.metadata, "resampled": {"fps": fps, "kind": kind, "step_dt": traj.dt}}
    if jumps:
        meta["jumps"] = jumps
    facing = None
    if traj.has_own_facing:  # turned through, the short way
        from crowdmotion.facing import wrap

        s2 = s[..., 0]
        yaw = np.unwrap(traj.facing, axis=0)
        facing = wrap(yaw[k] * (1 - s2) + yaw[np.minimum(k + 1, traj.n_frames - 1)] * s2)
    return Trajectories(pos, 1.0 / fps, ids=traj.ids, group=traj.group, radius=traj.radius, active=active,
                        metadata=meta, facing=facing, stage=stage)


def slowed(traj: Trajectories, factor: float) -> Trajectories:
    """``traj`` played ``factor`` times slower at its own frame rate: the frames at
    t / factor, linearly between the old ones (an agent is active at a new frame when it is
    at both old frames around it). A new frame's straight move to the next cuts the
    corner at an old frame between them a little: audit the result where that matters."""
    n = int(np.floor((traj.n_frames - 1) * factor + 1e-9)) + 1
    u = np.arange(n) / factor
    k = np.minimum(np.floor(u).astype(int), traj.n_frames - 2)
    s = (u - k)[:, None, None]
    pos = traj.positions[k] * (1 - s) + traj.positions[k + 1] * s
    held = np.minimum(np.ceil(u - 1e-9).astype(int), traj.n_frames - 1)  # the old frame each new one ends in
    active = None
    if traj.active is not None:
        active = traj.active[k] & traj.active[held]
    meta = {**traj.metadata, "slowed_by": factor}
    stage = None
    if traj.stage is not None:  # each new frame in the stage of the old frame it ends in, as resample does
        stage = traj.stage[held] if active is None else np.where(active, traj.stage[held], -1).astype(traj.stage.dtype)
    return Trajectories(pos, traj.dt, ids=traj.ids, group=traj.group, radius=traj.radius, active=active, metadata=meta,
                        stage=stage)


def _along(P: np.ndarray, u: np.ndarray, kind: str) -> np.ndarray:
    """Positions at ``u`` (steps from frame 0, within the frames) along the frames ``P``
    (T, N, D) joined by ``kind`` (see :func:`resample`)."""
    n = P.shape[0]
    if n == 1:
        return np.repeat(P, len(u), axis=0)
    k = np.minimum(np.floor(u).astype(int), n - 2)
    s = (u - k)[:, None, None]
    if kind == "linear":
        return P[k] * (1 - s) + P[k + 1] * s
    if kind == "catmull-rom":
        p0 = P[np.maximum(k - 1, 0)]
        p1, p2 = P[k], P[k + 1]
        p3 = P[np.minimum(k + 2, n - 1)]
        return 0.5 * ((2 * p1) + (-p0 + p2) * s + (2 * p0 - 5 * p1 + 4 * p2 - p3) * s**2
                      + (-p0 + 3 * p1 - 3 * p2 + p3) * s**3)
    # uniform cubic B-spline, control points the frames with reflected ends
    C = np.concatenate([2 * P[:1] - P[1:2], P, 2 * P[-1:] - P[-2:-1]])  # C[k + 1] = P[k]
    p0, p1, p2, p3 = C[k], C[k + 1], C[k + 2], C[k + 3]
    return ((1 - s) ** 3 * p0 + (3 * s**3 - 6 * s**2 + 4) * p1 + (-3 * s**3 + 3 * s**2 + 3 * s + 1) * p2
            + s**3 * p3) / 6.0


def _lazy_facing(name: str) -> property:
    """``Trajectories.facing`` / ``facing_pitch``: the constructor's value, or derived from
    the motion when first read."""
    private = "_" + name

    def get(self) -> np.ndarray:
        if getattr(self, private, None) is None:
            self._derive_facing()
        return getattr(self, private)

    def set(self, value) -> None:
        setattr(self, private, value)

    return property(get, set, doc=f"(T, N) {name}, radians (see the class docstring)")


# after @dataclass has made __init__ (which assigns these through the setters)
Trajectories.facing = _lazy_facing("facing")
Trajectories.facing_pitch = _lazy_facing("facing_pitch")
