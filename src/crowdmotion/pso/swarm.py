"""The particle-swarm engine: many swarms stepped together, and the paper's behaviours
``gather`` (group gathering, Fig. 5) and ``follow`` (target following, Fig. 6).

Canonical PSO (Kennedy & Eberhart 1995), as SPEC §3 fixes the paper's model: each
particle has position x, velocity v, personal best p (its closest position to the
target so far) and its swarm's best g::

    v ← χ·(w·v + c1·r1·(p − x) + c2·r2·(g − x)),   each component clamped to ±v_max
    x ← x + v                                       (the iterates are the path)

with r1, r2 ~ U(0, 1) per axis. Obstacle and agent avoidance redirect the step by the
paper's eqs. (4)–(5) (see :mod:`crowdmotion.pso._kernels`).

A documented addition against stagnation: g is the best position found, not the target,
so a swarm that has collapsed onto a poor best (e.g. one that went over a cluster of
obstacles and pressed against the scene's ceiling 20 m above its target) no longer feels
any pull towards the target and stands there for good. When a swarm's best has not come
nearer its target for ``stall_iterations`` iterations and none of its particles has
arrived, g ← the target itself; the next better position found replaces it as usual.
``stats["stall_pulls"]`` counts how often that happened.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from crowdmotion._rng import step_key
from crowdmotion.geometry import finite_array
from crowdmotion.groups import Group, MovingTarget, Points, Rect
from crowdmotion.interrupts import step_loop
from crowdmotion.placement import spawn_groups
from crowdmotion.pso import _kernels as K
from crowdmotion.pso.obstacles import ObstacleArrays, obstacle_field
from crowdmotion.pso.params import PSOParams, make_params
from crowdmotion.scene import Obstacle, Scene
from crowdmotion.trajectories import Trajectories, held_stages

COUNTER_NAMES = ("obstacle_redirects", "degenerate_redirects", "agent_redirects", "rule_conflicts",
                 "separation_truncations", "separation_stops", "obstacle_stops", "joins")
# the Swarm's per-particle arrays: remove and add keep them in step
PER_PARTICLE = ("x", "v", "swarm", "radius", "stopped", "arrival_iteration", "redirected", "pb", "pbd")
IMPROVEMENT = 1e-6  # metres: a swarm best nearer by less than this has not improved


class Swarm:
    """Particle swarms (one per target) stepped together in one scene.

    Parameters
    ----------
    starts : (N, D) start positions of all particles
    swarm_of : (N,) int, swarm index of each particle (0 .. G-1)
    targets : (G, D) target of each swarm
    radius : body radius, one value or (N,)
    params : :class:`PSOParams` (defaults: the paper's)
    scene : bounds and obstacles (circles/spheres, boxes); default: open bounds round
        the starts and targets
    rng : numpy Generator (the seed of every draw)
    """

    def __init__(self, starts, swarm_of, targets, radius=0.25, params: PSOParams | None = None,
                 scene: Scene | None = None, rng: np.random.Generator | None = None):
        self.params = params = PSOParams() if params is None else params
        x = finite_array(starts, "starts")
        if x.ndim != 2 or x.shape[1] not in (2, 3):
            raise ValueError(f"starts must have shape (N, 2 or 3), got {x.shape}")
        n, d = x.shape
        if n == 0:
            raise ValueError("a swarm needs at least one particle, got 0")
        tg = finite_array(targets, "targets").reshape(-1, d) if np.size(targets) % d == 0 else None
        if tg is None:
            raise ValueError(f"targets must be {d}D points like the starts, got {np.asarray(targets).tolist()}")
        sw = np.asarray(swarm_of, dtype=np.int64).reshape(-1)
        if sw.shape != (n,) or sw.min() < 0 or sw.max() >= len(tg):
            raise ValueError(f"swarm_of must give each of the {n} particles a swarm in 0..{len(tg) - 1}")
        r = finite_array(radius, "radius").reshape(-1)
        r = np.broadcast_to(r, (n,)).astype(float) if r.size in (1, n) else None
        if r is None or np.any(r <= 0):
            raise ValueError(f"radius must be positive, one value or one per particle, got {radius!r}")
        self.scene = scene if scene is not None else default_scene(x, tg, r.max())
        if self.scene.dim != d:
            raise ValueError(f"the scene is {self.scene.dim}D but the particles are {d}D")
        self.obstacles = ObstacleArrays.from_scene(self.scene)
        self._check_targets(tg, r.max())
        clear = self.scene.obstacle_distance(x, 0.0) - r
        if np.any(clear < 0):
            i = int(np.argmin(clear))
            raise ValueError(f"particle {i} starts inside an obstacle at {x[i].tolist()}")
        self.rng = np.random.default_rng() if rng is None else rng
        self.dim, self.n, self.n_swarms = d, n, len(tg)
        self.vmax = np.asarray(params.axis_vmax(d), float)
        self.x, self.swarm, self.radius, self.target = x.copy(), sw, r, tg.copy()
        self.v = self.rng.uniform(-self.vmax, self.vmax, size=(n, d))
        self.stopped = np.zeros(n, bool)
        self.arrival_iteration = np.full(n, -1, np.int64)
        self.iteration = 0
        self.counters = np.zeros(K.N_COUNTERS, np.int64)
        self.redirected = np.zeros(n, np.int64)  # obstacle redirects per particle, eqs. (4)-(5)
        self.stale = np.zeros(len(tg), np.int64)  # iterations since each swarm's best improved
        self.stall_pulls = 0
        self.pb, self.pbd = self.x.copy(), np.full(n, np.inf)
        self.gb, self.gbd = self.target.copy(), np.full(self.n_swarms, np.inf)
        self._reset_memory(np.ones(self.n_swarms, bool))
        counts = np.bincount(sw, minlength=self.n_swarms)
        rmax = np.zeros(self.n_swarms)
        np.maximum.at(rmax, sw, r)
        self.gather_radius = gather_radius(counts, rmax, d, params.threshold, params.gather_slack)
        lo, hi = self.scene.bounds
        s_max = float(np.linalg.norm(self.vmax))
        self._reach = max(params.avoid_radius + s_max, 2 * float(r.max()) + 2 * s_max)
        h = max(self._reach, float(np.max(hi - lo)) / (4.0 * n + 64) ** (1.0 / d))
        self._lo, self._hi = lo.astype(float).copy(), hi.astype(float).copy()
        self._grid = (self._lo, h, np.maximum(1, np.ceil((hi - lo) / h)).astype(np.int64))
        self.moved = 0
        self.particle_iterations = 0  # particles stepped, summed over the iterations
        ob = self.obstacles
        expand = params.detection + float(r.max()) + s_max
        self._obstacle_grid = ob.grid(expand, *self._grid)

    # ---- targets -----------------------------------------------------------------------
    def _check_targets(self, targets, r):
        clear = self.scene.obstacle_distance(targets, 0.0)
        bad = np.flatnonzero(clear < r)
        if len(bad):
            g = int(bad[0])
            raise ValueError(f"the target of swarm {g}, {targets[g].tolist()}, is covered by an obstacle "
                             f"(clearance {clear[g]:.3g} < particle radius {r:g})")
        inside = self.scene.contains(targets)
        if not inside.all():
            g = int(np.flatnonzero(~inside)[0])
            raise ValueError(f"the target of swarm {g}, {targets[g].tolist()}, lies outside the scene bounds")

    def _reset_memory(self, which: np.ndarray) -> None:
        """Personal bests become the current positions; swarm bests are recomputed."""
        sel = which[self.swarm]
        dist = np.linalg.norm(self.x - self.target[self.swarm], axis=1)
        self.pb[sel], self.pbd[sel] = self.x[sel], dist[sel]
        self.gbd[which] = np.inf
        K.update_bests(self.x, self.pb, self.pbd, self.gb, self.gbd, self.swarm, self.target,
                       np.zeros(self.n, bool), 0.0, self.stopped, self.arrival_iteration, self.iteration)
        arrived = sel & (dist <= self.params.threshold)
        self.stopped[sel] = arrived[sel]
        self.arrival_iteration[sel] = np.where(arrived[sel], self.iteration, -1)

    def retarget(self, targets, which=None) -> None:
        """Move the targets of the swarms in ``which`` (all by default): their memories are
        reset to the current positions and their particles start moving again."""
        tg = finite_array(targets, "targets").reshape(-1, self.dim)
        mask = np.ones(self.n_swarms, bool) if which is None else np.asarray(which, bool)
        self._check_targets(tg[mask], float(self.radius.max()))
        self.target[mask] = tg[mask]
        self._reset_memory(mask)

    def remove(self, which) -> None:
        """Take the particles ``which`` (indices into the current ones) out of the scene:
        they are neither stepped nor avoided any more, and the rest keep their state
        (velocities, bests, draws); indices of the rest close up, in order."""
        keep = np.ones(self.n, bool)
        keep[np.asarray(which, dtype=np.int64)] = False
        for name in PER_PARTICLE:
            setattr(self, name, np.ascontiguousarray(getattr(self, name)[keep]))
        self.n = int(keep.sum())

    def add(self, x: np.ndarray, v: np.ndarray, swarm_of: np.ndarray, radius: np.ndarray) -> None:
        """Put particles (positions ``x``, velocities ``v``, swarms ``swarm_of``, radii
        ``radius``) into the scene after the rest, e.g. a swarm that entered late (see
        :class:`crowdmotion.pso.routes.PSOWalkers`): from now on they are stepped and
        avoided; their swarms' memories start afresh from where they stand."""
        x = np.asarray(x, float).reshape(-1, self.dim)
        sw = np.asarray(swarm_of, dtype=np.int64).reshape(-1)
        k = len(x)
        fresh = {"x": x, "v": np.asarray(v, float).reshape(-1, self.dim), "swarm": sw,
                 "radius": np.asarray(radius, float).reshape(-1), "stopped": np.zeros(k, bool),
                 "arrival_iteration": np.full(k, -1, np.int64), "redirected": np.zeros(k, np.int64),
                 "pb": x.copy(), "pbd": np.full(k, np.inf)}
        for name in PER_PARTICLE:
            setattr(self, name, np.ascontiguousarray(np.concatenate([getattr(self, name), fresh[name]])))
        self.n += k
        which = np.zeros(self.n_swarms, bool)
        which[sw] = True
        self.stale[which] = 0
        self._reset_memory(which)

    # ---- one iteration ------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return bool(self.stopped.all())

    def iterate(self) -> None:
        """One PSO iteration of every swarm, with the avoidance rules the params switch on
        (with no particle in the scene, as while every swarm waits to enter, time passes)."""
        p = self.params
        if not self.n:
            self.iteration += 1
            return
        moving = ~self.stopped
        self.moved += int(moving.sum())
        self.particle_iterations += self.n
        key = step_key(self.rng)
        K.propose_velocities(self.x, self.v, self.pb, self.gb, self.swarm, moving, p.w, p.c1, p.c2, p.chi,
                             self.vmax, key)
        ob = self.obstacles
        joined = np.zeros(self.n, bool)
        has_obstacles = len(ob.sr) + len(ob.bl) > 0
        if p.avoid_agents or has_obstacles:
            dist = np.empty(self.n)
            K.target_distances(self.x, self.swarm, self.target, dist)
            idx = np.flatnonzero(moving)
            order = idx[np.argsort(dist[idx], kind="stable")]
            origin, h, dims = self._grid
            start, items = K.build_grid(self.x, origin, h, dims)
            newx = self.x.copy()
            lo, hi = self._lo, self._hi
            K.avoid_and_commit(order, self.x, self.v, newx, self.radius, self.swarm, self.stopped, joined,
                               p.avoid_obstacles, p.avoid_agents, p.avoid_agents and p.separation, p.detection,
                               p.avoid_radius, float(np.cos(np.deg2rad(p.avoid_angle_deg))), p.join_gap,
                               self.target, self.gather_radius,
                               ob.sc, ob.sr, ob.bl, ob.bu, *self._obstacle_grid, lo, hi, origin, h, dims, start,
                               items, self._reach, key, self.counters, self.redirected)
            self.x = newx
        else:
            K.advance_free(self.x, self.v, self.radius, self._lo, self._hi)
        self.iteration += 1
        before = self.gbd.copy()
        K.update_bests(self.x, self.pb, self.pbd, self.gb, self.gbd, self.swarm, self.target, moving,
                       p.threshold, self.stopped, self.arrival_iteration, self.iteration)
        self._pull_stalled_swarms(before)
        if p.avoid_agents:
            newly = joined & ~self.stopped
            self.stopped |= newly
            self.arrival_iteration[newly] = self.iteration

    def _pull_stalled_swarms(self, before: np.ndarray) -> None:
        """g ← target for swarms stalled ``stall_iterations`` iterations (module docstring)."""
        limit = self.params.stall_iterations
        if limit <= 0:
            return
        improved = self.gbd < before - IMPROVEMENT
        arrived = np.bincount(self.swarm, weights=self.stopped, minlength=self.n_swarms) > 0
        self.stale = np.where(improved | arrived, 0, self.stale + 1)
        stalled = self.stale >= limit
        if stalled.any():
            self.gb[stalled] = self.target[stalled]
            self.stale[stalled] = 0
            self.stall_pulls += int(stalled.sum())

    @property
    def stats(self) -> dict:
        """Counts of the avoidance rules and guards so far (see :data:`COUNTER_NAMES`)."""
        out = {name: int(c) for name, c in zip(COUNTER_NAMES, self.counters)}
        out["particles_redirected"] = int(np.count_nonzero(self.redirected))
        out["stall_pulls"] = self.stall_pulls
        out["particle_iterations"] = int(self.particle_iterations)
        out["moving_particle_iterations"] = self.moved
        return out


PACKING_DENSITY = {2: np.pi / (2 * np.sqrt(3)), 3: np.pi / (3 * np.sqrt(2))}


def gather_radius(count, radius, dim: int, threshold: float, slack: float) -> np.ndarray:
    """The group arrival rule's radius: bodies cannot all sit within the threshold of one
    point, so a group gathers within R = threshold + slack · r · (N / φ)^(1/D), where
    r (N/φ)^(1/D) is the radius of the ball that N bodies fill at the densest packing
    density φ (0.9069 for discs, 0.7405 for balls)."""
    count = np.asarray(count, float)
    return threshold + slack * np.asarray(radius, float) * (count / PACKING_DENSITY[dim]) ** (1.0 / dim)


def default_scene(starts, targets, radius: float, obstacles: Sequence[Obstacle] = ()) -> Scene:
    """Bounds round the starts and targets, padded by a quarter of their extent (≥ 5 m)."""
    pts = np.concatenate([np.asarray(starts, float), np.asarray(targets, float)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = np.maximum(0.25 * (hi - lo), 5.0) + radius
    return Scene(bounds=(lo - pad, hi + pad), obstacles=list(obstacles))


# ---- results -----------------------------------------------------------------------------
@dataclass
class SwarmRun:
    """A swarm run: the iterates and what happened.

    paths : (T, N, D)      positions after each iteration (frame 0: the starts)
    swarm : (N,) int       swarm of each particle
    targets : (T, G, D)    each swarm's target at each frame
    stopped : (N,) bool    particles that had arrived (threshold, or gathered) at the end
    arrival_iteration : (N,) int   iteration of arrival, -1 if never
    radius : (N,)          body radii
    scene : Scene          the scene, generated obstacles included
    stats : dict           rule and guard counts
    iteration_time : float seconds per iteration
    partial : bool         stopped early by Ctrl-C
    """

    paths: np.ndarray
    swarm: np.ndarray
    targets: np.ndarray
    stopped: np.ndarray
    arrival_iteration: np.ndarray
    radius: np.ndarray
    scene: Scene
    params: PSOParams
    stats: dict = field(default_factory=dict)
    iteration_time: float = 0.25
    partial: bool = False
    active: np.ndarray | None = None  # (T, N) particles still in the scene (None: all, always)
    stage: np.ndarray | None = None   # (T, N) each particle's route stage id (None: no routes)
    stages: dict | None = None        # the stage table per group on a route

    @property
    def arrival_rate(self) -> float:
        return float(self.stopped.mean())

    def within_threshold(self, frame: int = -1) -> np.ndarray:
        """(N,) bool: particle within the threshold of its swarm's target at ``frame``."""
        d = np.linalg.norm(self.paths[frame] - self.targets[frame][self.swarm], axis=1)
        return d <= self.params.threshold

    def trajectories(self, group_names: Sequence[str] | None = None, fps: float | None = None,
                     smoothing: str | None = None, max_speed=None) -> Trajectories:
        """World-space :class:`Trajectories`, one frame per iteration or resampled to ``fps``.

        ``smoothing`` (default: ``params.smoothing``): "linear", the iterates with straight
        moves between them; "relaxed", those paths relaxed for smooth root motion (see
        :func:`relaxed`), no agent faster than its ``max_speed`` (a number or one per
        particle; default: its own fastest step) or than its own fastest step."""
        from crowdmotion import __version__
        from crowdmotion.trajectories import resample

        names = np.array(list(group_names) if group_names is not None
                         else [f"swarm{g}" for g in range(self.targets.shape[1])], dtype=object)
        traj = Trajectories(self.paths, self.iteration_time, group=names[self.swarm], radius=self.radius,
                            metadata={"method": "pso", "params": self.params.model_dump(),
                                      "scene": self.scene.to_dict(), "version": __version__,
                                      "iterations": int(self.paths.shape[0] - 1), "stats": dict(self.stats),
                                      "partial": self.partial}, active=self.active, stage=self.stage)
        if self.stages is not None:
            traj.metadata["stages"] = self.stages
        if (self.params.smoothing if smoothing is None else smoothing) == "relaxed":
            out = relaxed(traj, fps, self.params.smoothing_window, self.scene, max_speed)
        else:
            out = traj if fps is None else resample(traj, fps, "linear")
        if self.stage is not None and out is not traj:  # each new frame holds the stage of the iteration it ends in
            out.stage = held_stages(self.stage, out.times, self.iteration_time, out.active_mask)
        return out


# The relaxed paths' pushes keep bodies this far apart (metres), and settle with up to this
# many rounds of pushes alone: a swarm gathers tightly round its target, where the last
# round's averaging leaves bodies a little nearer than MDP's 1 cm margin, and a step the
# audit then finds touching falls back to its straight move, which can bring the bodies
# beside it together in turn (on pso_following seed 0 that ran through every step).
RELAX_MARGIN = 0.03
RELAX_SETTLE = 20


def relaxed(traj: Trajectories, fps: float | None, window_s: float, scene: Scene, max_speed=None) -> Trajectories:
    """A run's iterates (``traj``, one frame per iteration) as smooth root motion at
    ``fps`` (None: at the iterations): the PSO path jerks at every iteration, whose velocity
    is drawn afresh (at 24 fps the paper's paths reach p95 accelerations of 20-70 m/s²), so
    the paths are relaxed as MDP's are (:func:`crowdmotion.path_relaxation.relaxed_trajectories`:
    every frame averaged over ``window_s`` seconds, bodies pushed apart and out of the
    obstacles, audited in continuous time, a step that would still touch or outrun
    ``max_speed`` keeping its straight move). The first and last frames stay where they
    are, but for the pushes that keep bodies ``RELAX_MARGIN`` apart (a gathered swarm packs
    closer than that: its last frames move by a few centimetres)."""
    from crowdmotion.path_relaxation import relaxed_trajectories

    limit = np.zeros(traj.n_agents) if max_speed is None else np.broadcast_to(
        np.asarray(max_speed, float), (traj.n_agents,))
    return relaxed_trajectories(traj, fps, window_s, scene, limit, margin=RELAX_MARGIN, settle=RELAX_SETTLE,
                                keep_speed=True)


def _record(swarm: Swarm, n: int, frames: list, targets: list, progress: Callable[[int], None] | None,
            until: Callable[[Swarm], bool] | None = None) -> None:
    for _ in range(n):
        swarm.iterate()
        frames.append(swarm.x.copy())
        targets.append(swarm.target.copy())
        if progress is not None:
            progress(1)
        if until is not None and until(swarm):
            break


def drive(swarm: Swarm, schedule=None, targets_at: Callable[[float], np.ndarray] | None = None, which=None,
          progress: Callable[[int], None] | None = None) -> SwarmRun:
    """Run a swarm and record its iterates (never more than ``params.max_iterations``).

    Without a ``schedule``: ``params.iterations`` iterations, fewer once every particle
    has stopped (``stop_when_done``). With one (times of the target updates, see
    :func:`follow_schedule`): at each time after the first the swarms in ``which`` get
    ``targets_at(t)`` as their targets, then ``params.iterations`` iterations run.
    """
    p = swarm.params
    frames, targets = [swarm.x.copy()], [swarm.target.copy()]
    with step_loop() as loop:  # Ctrl-C: keep the iterations so far, marked partial
        if schedule is None:
            until = (lambda s: s.done) if p.stop_when_done else None
            if not (until and swarm.done):
                _record(swarm, min(p.iterations, p.max_iterations), frames, targets, progress, until)
        else:
            for u, t in enumerate(schedule):
                if u:
                    swarm.retarget(targets_at(t), which=which)
                _record(swarm, min(p.iterations, p.max_iterations + 1 - len(frames)), frames, targets, progress)
                if len(frames) > p.max_iterations:
                    break
    partial = loop.stopped
    n = min(len(frames), len(targets))  # a step cut short
    frames, targets = frames[:n], targets[:n]
    return SwarmRun(np.array(frames), swarm.swarm.copy(), np.array(targets), swarm.stopped.copy(),
                    swarm.arrival_iteration.copy(), swarm.radius.copy(), swarm.scene, p, swarm.stats,
                    p.iteration_time, partial)


# ---- the paper's behaviours ----------------------------------------------------------------
def _start_box(start_range, dim: int) -> tuple[np.ndarray, np.ndarray]:
    if np.ndim(start_range) == 0:
        r = float(start_range)
        if not (np.isfinite(r) and r > 0):
            raise ValueError(f"start_range must be a positive number (the box ±start_range), got {start_range!r}")
        return np.full(dim, -r), np.full(dim, r)
    lo, hi = (finite_array(c, "start_range").reshape(-1) for c in start_range)
    if lo.shape != (dim,) or hi.shape != (dim,) or np.any(hi <= lo):
        raise ValueError(f"start_range must be a number or a ({dim}D lower, upper) box, got {start_range!r}")
    return lo, hi


def _setup(targets, n_particles, start_range, starts, obstacles, radius, params, rng, bounds, later=None):
    """Scene (with generated obstacles), starts and swarm indices for gather/follow;
    ``later`` are target positions still to come (kept clear and inside the bounds)."""
    tg = finite_array(targets, "target")
    tg = tg.reshape(1, -1) if tg.ndim == 1 else tg
    if tg.ndim != 2 or tg.shape[1] not in (2, 3) or len(tg) == 0:
        raise ValueError(f"target must be a 2D/3D point or a (G, D) array of them, got shape {tg.shape}")
    d = tg.shape[1]
    if int(n_particles) != n_particles or n_particles < 1:
        raise ValueError(f"n_particles must be a positive whole number, got {n_particles!r}")
    n_particles = int(n_particles)
    r = float(radius)
    if not (np.isfinite(r) and r > 0):
        raise ValueError(f"radius must be a positive number, got {radius!r}")
    lo, hi = _start_box(start_range, d)
    obs = list(obstacles.obstacles) if isinstance(obstacles, Scene) else list(obstacles or [])
    if params.obstacle_field is not None:
        region_lo, region_hi = np.minimum(lo, tg.min(0)), np.maximum(hi, tg.max(0))
        clear = tg if later is None else np.concatenate([tg, later])
        obs += obstacle_field(params.obstacle_field, d, region_lo, region_hi, clear, params.threshold, rng)
    if isinstance(obstacles, Scene):
        scene = Scene(obstacles.bounds, obs)
    elif bounds is not None:
        scene = Scene(bounds, obs)
    else:
        box = np.stack([lo, hi])
        scene = default_scene(box, tg if later is None else np.concatenate([tg, later]), r, obs)
    if starts is not None:
        x = finite_array(starts, "starts").reshape(-1, d)
        if len(x) % len(tg):
            raise ValueError(f"starts: {len(x)} positions do not split evenly over {len(tg)} swarms")
        per = len(x) // len(tg)
    else:
        per = n_particles
        groups = [Group(name=f"swarm{g}", count=per, spawn=Rect(lo, hi), goal=Points(tg[g][None]), radius=r)
                  for g in range(len(tg))]
        x = spawn_groups(scene, groups, params.spawn_gap, rng, overlap=not params.avoid_agents)[0]
    return scene, x, np.repeat(np.arange(len(tg)), per), tg


def gather(target=(0.0, 0.0, 0.0), n_particles: int = 30, *, start_range=30.0, starts=None, obstacles=None,
           radius: float = 0.25, bounds=None, params: PSOParams | None = None, rng=None,
           progress: Callable[[int], None] | None = None, **overrides) -> SwarmRun:
    """Group gathering (paper Fig. 5): particles spread over the start range converge on
    the target; a particle within ``params.threshold`` stops.

    ``target`` is one point or a (G, D) array: G swarms of ``n_particles`` run at once.
    ``start_range`` is the paper's ±30 box (a number) or a (lower, upper) box; ``starts``
    overrides it with explicit positions (N, D), swarms in consecutive blocks.
    ``obstacles`` is a Scene (its bounds are used) or a list of Circle/Sphere/Box.
    Keyword ``overrides`` set any :class:`PSOParams` field (``iterations=200``, ...).
    Runs ``params.iterations`` iterations, fewer when every particle has stopped.
    """
    params = make_params(params, **overrides)
    rng = np.random.default_rng() if rng is None else rng
    scene, x, sw, tg = _setup(target, n_particles, start_range, starts, obstacles, radius, params, rng, bounds)
    return drive(Swarm(x, sw, tg, radius, params, scene, rng), progress=progress)


def follow_schedule(start: float, end: float, iterations_per_update: int, iteration_time: float) -> np.ndarray:
    """Times of the target updates: every k iterations from ``start`` until ``end`` is read."""
    period = iterations_per_update * iteration_time
    n_updates = int(np.ceil((end - start) / period - 1e-9)) + 1
    return start + period * np.arange(n_updates)


def follow(target_path, n_particles: int = 30, *, start_range=30.0, starts=None, obstacles=None,
           radius: float = 0.25, bounds=None, params: PSOParams | None = None, rng=None,
           progress: Callable[[int], None] | None = None, **overrides) -> SwarmRun:
    """Target following (paper Fig. 6): the target moves along ``target_path`` (a
    :class:`MovingTarget` or ``(times, positions)`` keyframes, seconds); it is read every
    ``params.iterations`` iterations (k, the paper's 50–100), and the swarm runs k
    iterations towards each new position. One iteration lasts ``params.iteration_time``
    seconds, so a larger k samples the target's motion more coarsely and loses its
    detail (the paper's Fig. 2). After the last update the swarm runs k more iterations.
    """
    params = make_params(params, **overrides)
    rng = np.random.default_rng() if rng is None else rng
    path = target_path if isinstance(target_path, MovingTarget) else MovingTarget(*target_path)
    times = follow_schedule(path.times[0], path.times[-1], params.iterations, params.iteration_time)
    scene, x, sw, tg = _setup(path.at(times[0]), n_particles, start_range, starts, obstacles, radius, params,
                              rng, bounds, later=path.positions)
    return drive(Swarm(x, sw, tg, radius, params, scene, rng), times, lambda t: path.at(t)[None], progress=progress)
