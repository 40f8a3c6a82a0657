"""Metrics every method is judged by: continuous-time collisions, paths, arrival, speed."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from crowdmotion.floor import DiscFloor
from crowdmotion.geometry import closest_approach, minimise_convex_on_segment
from crowdmotion.scene import Box, Obstacle, Polygon, Scene, _Round, scene_of
from crowdmotion.trajectories import Trajectories

MAX_EVENTS = 100
ORIENTATION_NOTE_DEG = 5.0  # a formation that ends turned further than this off its heading is named in the line


@dataclass
class CollisionEvent:
    """One overlap found between two frames.

    ``kind`` is ``"agent-agent"`` or ``"agent-obstacle"``; ``a`` is an agent index,
    ``b`` the other agent or the obstacle index (-1: the scene's bounds); ``time`` the moment of deepest overlap
    (seconds); ``penetration`` how far the bodies overlap there (metres).
    """

    kind: str
    frame: int
    time: float
    a: int
    b: int
    penetration: float
    position: tuple[float, ...]


@dataclass
class CollisionReport:
    """Result of :func:`collision_audit`: counts of overlapping (pair, interval)s."""

    agent_agent: int = 0
    agent_obstacle: int = 0
    worst_agent_agent: float = 0.0
    worst_agent_obstacle: float = 0.0
    events: list[CollisionEvent] = field(default_factory=list)

    @property
    def clean(self) -> bool:
        return self.agent_agent == 0 and self.agent_obstacle == 0

    def as_dict(self) -> dict:
        return {
            "agent_agent_overlaps": self.agent_agent,
            "agent_obstacle_penetrations": self.agent_obstacle,
            "worst_agent_agent_penetration_m": self.worst_agent_agent,
            "worst_agent_obstacle_penetration_m": self.worst_agent_obstacle,
            "first_events": [e.__dict__ for e in sorted(self.events, key=lambda e: e.time)[:10]],
        }


def _interval_mask(traj: Trajectories) -> np.ndarray:
    """(T-1, N): agent takes part in the interval [f, f+1] (active at both ends, and not
    jumping in it: ``metadata["jumps"]``, ``[time, agent]`` pairs, a live run's ``place()``)."""
    a = traj.active_mask
    mask = a[:-1] & a[1:]
    for f, i in traj.jump_steps():
        mask[f, i] = False
    return mask


def agent_overlaps(traj: Trajectories, tolerance: float = 0.0, max_events: int = MAX_EVENTS,
                   intervals: np.ndarray | None = None) -> tuple[int, float, list[CollisionEvent]]:
    """Agent pairs closer than the sum of their radii at any time, frames linearly joined.

    Candidate pairs per interval come from a cKDTree at the interval's first frame with
    search radius 2*max radius + 2*max displacement, so no pair can be missed; each
    candidate is then solved exactly (closest approach of two linear motions).
    An overlap counts when it exceeds ``tolerance`` metres; the ``max_events`` deepest of
    each interval's are listed (up to that many in all). ``intervals`` ((T-1,) bool): check
    only those intervals frame f -> f + 1 (default all).
    """
    pos = traj.positions
    inside = _interval_mask(traj)
    rmax = float(traj.radius.max()) if traj.n_agents else 0.0
    count, worst, events = 0, 0.0, []
    for f in (range(traj.n_frames - 1) if intervals is None else np.flatnonzero(intervals)):
        idx = np.flatnonzero(inside[f])
        if len(idx) < 2:
            continue
        p0 = pos[f, idx]
        dp = pos[f + 1, idx] - p0
        reach = 2 * rmax + 2 * float(np.sqrt((dp**2).sum(axis=1).max()))
        pairs = cKDTree(p0).query_pairs(reach, output_type="ndarray")
        if len(pairs) == 0:
            continue
        i, j = pairs[:, 0], pairs[:, 1]
        dist, t = closest_approach(p0[i] - p0[j], dp[i] - dp[j])
        pen = traj.radius[idx[i]] + traj.radius[idx[j]] - dist
        hit = np.flatnonzero(pen > tolerance)
        if len(hit) == 0:
            continue
        count += len(hit)
        worst = max(worst, float(pen[hit].max()))
        for h in hit[np.argsort(-pen[hit])][: max(0, max_events - len(events))]:
            where = p0[i[h]] + t[h] * dp[i[h]]
            events.append(
                CollisionEvent("agent-agent", f, (f + t[h]) * traj.dt, int(idx[i[h]]), int(idx[j[h]]),
                               float(pen[h]), tuple(map(float, where)))
            )
    return count, worst, events


def _segment_clearance(ob: Obstacle, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least signed distance from the segments a->b (in the obstacle's rest frame) to it."""
    if isinstance(ob, _Round):
        d, t = closest_approach(a - ob.center, b - a)
        return d - ob.radius, t
    if isinstance(ob, Box):
        return minimise_convex_on_segment(lambda t: ob.signed_distance(a + t[:, None] * (b - a)), len(a))
    if isinstance(ob, Polygon):
        lines = shapely.linestrings(np.stack([a, b], axis=1))
        d = shapely.distance(ob.geometry, lines)
        crossing = d <= 0
        if crossing.any():  # depth: the deepest of a few samples along the segment
            ts = np.linspace(0, 1, 33)
            sd = np.stack([ob.signed_distance(a[crossing] + s * (b - a)[crossing]) for s in ts])
            d = d.copy()
            d[crossing] = sd.min(axis=0)
        return d, np.full(len(a), 0.5)
    raise TypeError(f"unknown obstacle {ob!r}")  # pragma: no cover


EDGE_TOUCH_M = 1e-9  # a body clamped against the scene's edge touches it, to the last bit, without crossing


def obstacle_penetrations(
    traj: Trajectories, scene: Scene, tolerance: float = 0.0, max_events: int = MAX_EVENTS,
    intervals: np.ndarray | None = None,
) -> tuple[int, float, list[CollisionEvent]]:
    """Agent bodies entering obstacles at any time, frames (and obstacle keys) linearly joined.

    Each interval is checked in the obstacle's own frame, where the agent's relative
    motion is a straight segment; the least clearance along it is exact for circles,
    spheres and boxes, and exact in 2D for polygons (shapely). A body reaching past the
    scene's bounds counts as entering obstacle -1.
    """
    inside = _interval_mask(traj)
    if intervals is not None:
        inside = inside & np.asarray(intervals, dtype=bool)[:, None]
    times = traj.times
    f_idx, a_idx = np.nonzero(inside)
    if len(f_idx) == 0:
        return 0, 0.0, []
    radius = traj.radius[a_idx]
    count, worst, events = 0, 0.0, []
    for k, ob in enumerate(scene.obstacles):
        off = ob.offset(times)
        a = traj.positions[f_idx, a_idx] - off[f_idx]
        b = traj.positions[f_idx + 1, a_idx] - off[f_idx + 1]
        lo, hi = ob.bounds()
        near = np.all((np.minimum(a, b) - radius[:, None] <= hi) & (np.maximum(a, b) + radius[:, None] >= lo), axis=1)
        if ob.is_timed:  # an obstacle added or removed while running: the intervals it stood in
            near &= (times[f_idx + 1] > ob.present[0]) & (times[f_idx] < ob.present[1])
        sel = np.flatnonzero(near)
        if len(sel) == 0:
            continue
        clearance, t = _segment_clearance(ob, a[sel], b[sel])
        pen = radius[sel] - clearance
        hit = np.flatnonzero(pen > tolerance)
        if len(hit) == 0:
            continue
        count += len(hit)
        worst = max(worst, float(pen[hit].max()))
        for h in hit[np.argsort(-pen[hit])][: max(0, max_events - len(events))]:
            s = sel[h]
            f, i = int(f_idx[s]), int(a_idx[s])
            where = traj.positions[f, i] + t[h] * (traj.positions[f + 1, i] - traj.positions[f, i])
            events.append(CollisionEvent("agent-obstacle", f, (f + t[h]) * traj.dt, i, k,
                                         float(pen[h]), tuple(map(float, where))))
    # the scene's bounds are walls too (obstacle -1): a body's clearance from a side is
    # linear along a straight move, so its least is at one of the move's ends
    ends = np.stack([traj.positions[f_idx, a_idx], traj.positions[f_idx + 1, a_idx]])  # (2, n, dim)
    clear = scene.wall_clearance(ends)  # (2, n)
    pen = radius - clear.min(axis=0)
    hit = np.flatnonzero(pen > max(tolerance, EDGE_TOUCH_M))
    if len(hit):
        count += len(hit)
        worst = max(worst, float(pen[hit].max()))
        for h in hit[np.argsort(-pen[hit])][: max(0, max_events - len(events))]:
            f, i, end = int(f_idx[h]), int(a_idx[h]), int(np.argmin(clear[:, h]))
            events.append(CollisionEvent("agent-obstacle", f, (f + end) * traj.dt, i, -1, float(pen[h]),
                                         tuple(map(float, ends[end, h]))))
    return count, worst, events


def collision_audit(traj: Trajectories, scene: Scene | None = None, tolerance: float = 0.0,
                    max_events: int = MAX_EVENTS, intervals: np.ndarray | None = None) -> CollisionReport:
    """Continuous-time check of agent–agent overlaps and agent–obstacle penetrations.

    Positions between frames are linear interpolations. Returns counts of overlapping
    (pair, interval)s, the worst penetration depth of each kind and up to
    ``max_events`` events of each kind (where and when). ``tolerance`` (metres) ignores
    overlaps no deeper than it. ``intervals`` ((T-1,) bool): audit only those intervals
    frame f -> f + 1 (default all).
    """
    aa, worst_aa, ev_aa = agent_overlaps(traj, tolerance, max_events, intervals)
    ao, worst_ao, ev_ao = ((0, 0.0, []) if scene is None
                           else obstacle_penetrations(traj, scene, tolerance, max_events, intervals))
    return CollisionReport(aa, ao, worst_aa, worst_ao, ev_aa + ev_ao)


def path_length(traj: Trajectories) -> np.ndarray:
    """(N,) distance travelled by each agent while active, metres."""
    steps = np.linalg.norm(np.diff(traj.positions, axis=0), axis=-1)
    return (steps * _interval_mask(traj)).sum(axis=0)


def arrival(traj: Trajectories, goal_reached) -> tuple[np.ndarray, np.ndarray]:
    """Per agent: whether it reached its goal, and the time it first did (NaN if never).

    ``goal_reached(frame_positions) -> (N,) bool`` tells who is at the goal in a frame.
    An agent that despawns counts as arrived at the frame it was last active (one that
    was never active, or is still active at the end, does not).
    """
    at = np.stack([np.asarray(goal_reached(p), dtype=bool) for p in traj.positions])
    if traj.active is not None:
        act = traj.active
        left = act.any(axis=0) & ~act[-1]
        last = len(act) - 1 - np.argmax(act[::-1], axis=0)  # the last frame each agent was active
        at[last[left], np.flatnonzero(left)] = True
    arrived = at.any(axis=0)
    first = np.where(arrived, np.argmax(at, axis=0) * traj.dt, np.nan)
    return arrived, first


def summary(traj: Trajectories, scene: Scene | None = None, goal_reached=None, tolerance: float = 0.0) -> dict:
    """The metrics of one run as a flat, JSON-ready dict."""
    audit = collision_audit(traj, scene, tolerance)
    speed = traj.speed[:-1][_interval_mask(traj)] if traj.n_frames > 1 else np.zeros(0)
    out = {
        "agents": traj.n_agents,
        "frames": traj.n_frames,
        "duration_s": (traj.n_frames - 1) * traj.dt,
        "mean_path_length_m": float(path_length(traj).mean()) if traj.n_agents else 0.0,
        "mean_speed_mps": float(speed.mean()) if speed.size else 0.0,
        "max_speed_mps": float(speed.max()) if speed.size else 0.0,
        **audit.as_dict(),
    }
    if traj.n_frames > 2 and traj.n_agents:
        out["root_motion"] = root_motion(traj)
    if goal_reached is not None:
        arrived, t = arrival(traj, goal_reached)
        out["arrival_rate"] = float(arrived.mean()) if traj.n_agents else 0.0
        out["mean_time_to_goal_s"] = float(np.nanmean(t)) if arrived.any() else None
        out["time_to_goal_by_group_s"] = time_to_goal_by_group(traj, t)
    return out


ROOT_FPS = 24.0          # frames per second a DCC plays (export --fps 24, the USD)
ROOT_MOVING_MPS = 0.3    # walkers slower than this stand: their heading is not judged
ROOT_WINDOW_S = 1.0      # the moving average the path's wobble is measured from
ROOT_MAX_AGENTS = 400    # agents sampled (evenly by index) to keep the measure quick


def root_motion(traj: Trajectories, fps: float = ROOT_FPS) -> dict:
    """How smooth the root motion is that a character bound to these paths would play:
    the run resampled to ``fps`` along the cubic B-spline of its frames, as ``export
    --fps`` and the USD export give it (their collision check may turn a few steps back
    into straight moves; they count them), then, by central differences over the frames where an agent is active and moving
    faster than 0.3 m/s, the 95th percentile (and maximum) of its acceleration (m/s²), of
    its turn rate (rad/s, the heading change of its velocity) and of its distance from
    its own 1 s moving average (m: the wobble a walk cycle would show). At most 400 agents,
    evenly spread over the ids, are measured."""
    from crowdmotion.trajectories import resample

    pick = np.unique(np.linspace(0, traj.n_agents - 1, min(traj.n_agents, ROOT_MAX_AGENTS)).astype(int))
    sub = Trajectories(traj.positions[:, pick], traj.dt, radius=traj.radius[pick],
                       active=None if traj.active is None else traj.active[:, pick])
    tr = resample(sub, fps, "b-spline") if abs(traj.dt * fps - 1.0) > 1e-9 else sub
    p, act, h = tr.positions, tr.active_mask, tr.dt
    if len(p) < 3:
        return {}
    v = (p[2:] - p[:-2]) / (2 * h)
    acc = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=-1) / (h * h)
    moving = act[2:] & act[1:-1] & act[:-2] & (np.linalg.norm(v, axis=-1) > ROOT_MOVING_MPS)
    v_in, v_out = p[1:-1] - p[:-2], p[2:] - p[1:-1]  # the turn between the frame's two moves
    norm = np.linalg.norm(v_in, axis=-1) * np.linalg.norm(v_out, axis=-1)
    cos = np.clip(np.einsum("...k,...k->...", v_in, v_out) / np.where(norm > 0, norm, 1.0), -1.0, 1.0)
    turn = np.arccos(cos) / h
    half = max(1, int(round(ROOT_WINDOW_S * fps / 2)))
    width = 2 * half + 1
    csum = np.cumsum(np.concatenate([np.zeros((1,) + p.shape[1:]), p]), axis=0)
    mean = (csum[width:] - csum[:-width]) / width  # centred on frames half .. T-half-1
    alive = np.cumsum(np.concatenate([np.zeros((1, p.shape[1])), act]), axis=0)
    whole = (alive[width:] - alive[:-width]) == width
    centre = slice(half, len(p) - half)
    wobble = np.linalg.norm(p[centre] - mean, axis=-1)
    wob_ok = whole & moving[half - 1:len(p) - half - 1] if len(p) > width else np.zeros((0, p.shape[1]), bool)

    def stats(x: np.ndarray) -> dict:
        return {"p95": float(np.percentile(x, 95)), "max": float(x.max())} if x.size else {"p95": None, "max": None}

    return {"fps": fps, "acceleration_mps2": stats(acc[moving]), "turn_rate_rad_s": stats(turn[moving]),
            "deviation_from_1s_average_m": stats(wobble[wob_ok]), "agents_measured": int(len(pick))}


def with_arrival_times(report: dict, by_group: dict) -> dict:
    """``report`` (:func:`group_report`) with each group's ``time_to_goal_s`` the one the
    method measured (``by_group``, :func:`time_to_goal_by_group`) where it measured one:
    the frames alone miss the agents that arrive in the run's last frame, which stay in it."""
    for name, row in report.items():
        if by_group.get(name) is not None:
            row["time_to_goal_s"] = by_group[name]
    return report


def time_to_goal_by_group(traj: Trajectories, arrival_time: np.ndarray) -> dict:
    """Mean arrival time of each group's arrived agents (None where nobody arrived)."""
    t = np.asarray(arrival_time, dtype=float)
    out = {}
    for g in dict.fromkeys(traj.group.tolist()):
        sel = t[traj.group == g]
        out[str(g)] = float(np.nanmean(sel)) if np.isfinite(sel).any() else None
    return out


# ---- per-group behaviour (lateral spread, turning, density, mixing) -------------------------
DENSITY_RADIUS = 2.0  # metres: local density counts neighbours within this distance ...
DENSITY_FLOOR_MIN = 0.1  # ... over the walkable part of the disc, taken as at least this share of it
CLUSTER_LINK = 1.2  # metres: same-group agents this close (about half a metre apart) walk together
MIX_RADIUS = 2.0  # metres: neighbours whose group is compared for mixing
CONTACT_RADIUS = 5.0  # metres: an agent interacts with another group within this distance
MAX_SAMPLED_FRAMES = 200


def _first_last(traj: Trajectories) -> tuple[np.ndarray, np.ndarray]:
    """Each agent's first and last active frame index."""
    act = traj.active_mask
    first = np.argmax(act, axis=0)
    last = traj.n_frames - 1 - np.argmax(act[::-1], axis=0)
    return first, last


def group_report(traj: Trajectories, scene: Scene | None = None) -> dict:
    """Per-group behaviour measures from trajectories alone (any method).

    For each group: ``lateral_spread_m`` (frame-mean standard deviation of positions
    across the group's travel direction), ``lateral_deviation_m`` (mean of each agent's
    largest distance from its own start-to-end line), ``heading_change_rate_rad_s``
    (mean |Δheading| / dt while walking), ``mean_speed_mps``, ``speed_density_slope``
    (least-squares slope of speed against local density, m/s per agent/m²) with the
    density-binned speeds (``speed_by_density``), ``mixing_index`` (share of neighbours within 2 m from other
    groups, over agent-frames with another group within 5 m), ``same_group_neighbors``
    (same-group agents within 2 m at those moments), ``cluster_size`` and ``clusters``
    (at the moments another group is within 5 m of any agent: the mean size of the
    same-group cluster each agent is in — agents chained by links shorter than
    ``CLUSTER_LINK`` m, so a lone agent is a cluster of 1 — and the mean number of its
    group's clusters of two or more: A− of paper 004 §6 walks in clusters),
    ``time_to_goal_s`` (mean time from an agent's first frame to its last, over the agents
    that left: from entering, as the run's ``time_to_goal_by_group_s`` counts it, to within a
    frame; None when nobody left; a run's summary puts the method's own arrival times there,
    :func:`with_arrival_times`) and
    ``path_length_ratio`` (path length over start-to-end distance).

    Local density: the other agents within ``DENSITY_RADIUS`` (2 m) of an agent over the
    walkable area of that disc (inside the scene's bounds and outside its static obstacles,
    :class:`crowdmotion.floor.DiscFloor`; at least ``DENSITY_FLOOR_MIN`` of the disc), so
    a crowd against a wall, in a corridor or before a door reads as dense as it is.
    ``scene``: the run's scene (default: the one stored with ``traj``); without a 2D scene
    the whole disc's area (π · 4 m²) is taken.
    """
    act = traj.active_mask
    if scene is None:
        scene = scene_of(traj)
    floor = DiscFloor(scene, DENSITY_RADIUS) if scene is not None and scene.dim == 2 else None
    disc_area = np.pi * DENSITY_RADIUS**2
    pos = traj.positions[..., :2]
    first, last = _first_last(traj)
    n_idx = np.arange(traj.n_agents)
    start, end = pos[first, n_idx], pos[last, n_idx]
    lengths = path_length(traj)
    walked = act[:-1] & act[1:] if traj.n_frames > 1 else np.zeros((0, traj.n_agents), bool)
    speed = traj.speed
    heading = traj.heading
    frames = np.unique(np.linspace(0, traj.n_frames - 1, min(traj.n_frames, MAX_SAMPLED_FRAMES)).astype(int))
    groups = traj.group
    names = list(dict.fromkeys(groups.tolist()))
    mixing = {g: [] for g in names}
    same = {g: [] for g in names}
    cluster_size = {g: [] for g in names}
    clusters = {g: [] for g in names}
    dens_speed = {g: ([], []) for g in names}
    code = np.array([names.index(g) for g in groups.tolist()], dtype=np.int64)
    for f in frames:  # one tree per sampled frame serves density, mixing and contact
        idx = np.flatnonzero(act[f])
        if len(idx) < 2:
            continue
        p = pos[f, idx]
        gi = code[idx]
        tree = cKDTree(p)
        # local density: other active agents within DENSITY_RADIUS over the disc's walkable area
        walkable = disc_area if floor is None else np.maximum(floor.at(p), DENSITY_FLOOR_MIN * disc_area)
        rho = (np.asarray(tree.query_ball_point(p, DENSITY_RADIUS, return_length=True)) - 1) / walkable
        sp = speed[f, idx]
        other_near = np.zeros(len(idx))
        same_near = np.zeros(len(idx))
        pairs = tree.query_pairs(MIX_RADIUS, output_type="ndarray")
        if len(pairs):
            diff = (gi[pairs[:, 0]] != gi[pairs[:, 1]]).astype(float)
            for col in (0, 1):
                other_near += np.bincount(pairs[:, col], diff, len(idx))
                same_near += np.bincount(pairs[:, col], 1.0 - diff, len(idx))
        contact = np.zeros(len(idx), dtype=bool)
        far = tree.query_pairs(CONTACT_RADIUS, output_type="ndarray")
        if len(far):
            cross = far[gi[far[:, 0]] != gi[far[:, 1]]]
            contact[cross.ravel()] = True
        size, label = _same_group_clusters(tree, gi, contact.any())
        for k, g in enumerate(names):
            mine = gi == k
            if size is not None and mine.any():
                cluster_size[g].append(float(size[label[mine]].mean()))
                clusters[g].append(int(np.count_nonzero(size[np.unique(label[mine])] >= 2)))
            dens_speed[g][0].extend(rho[mine].tolist())
            dens_speed[g][1].extend(sp[mine].tolist())
            m = mine & contact
            same[g].extend(same_near[m].tolist())
            total = same_near[m] + other_near[m]
            mixing[g].extend((other_near[m][total > 0] / total[total > 0]).tolist())
    report = {}
    for g in names:
        sel = np.flatnonzero(groups == g)
        travel = (end[sel] - start[sel]).mean(axis=0)
        norm = np.linalg.norm(travel)
        u = travel / norm if norm > 0 else np.array([1.0, 0.0])
        nrm = np.array([-u[1], u[0]])
        lat = pos[:, sel] @ nrm
        a = act[:, sel]
        spreads = [lat[t, a[t]].std() for t in range(traj.n_frames) if a[t].sum() >= 2]
        d_own = end[sel] - start[sel]
        l_own = np.linalg.norm(d_own, axis=1)
        dev = []
        for j, i in enumerate(sel):
            if l_own[j] <= 1e-9:
                continue
            dhat = d_own[j] / l_own[j]
            rel = pos[first[i]:last[i] + 1, i] - start[i]
            dev.append(np.abs(rel[:, 0] * dhat[1] - rel[:, 1] * dhat[0]).max())
        w = walked[:, sel]
        moving = w & (speed[:-1, sel] > 0.05) & (speed[1:, sel] > 0.05)
        if traj.n_frames > 2:
            dth = np.angle(np.exp(1j * (heading[1:, sel] - heading[:-1, sel])))[:-1]
            turn = np.abs(dth)[moving[:-1]] / traj.dt if moving.shape[0] > 1 else np.zeros(0)
        else:
            turn = np.zeros(0)
        rho, sp = (np.asarray(x, dtype=float) for x in dens_speed[g])
        slope = float(np.polyfit(rho, sp, 1)[0]) if len(rho) > 2 and np.ptp(rho) > 0 else None
        bins = [0.0, 0.25, 0.5, 1.0, 2.0, np.inf]
        table = []
        for lo, hi in zip(bins[:-1], bins[1:]):
            m = (rho >= lo) & (rho < hi)
            if m.any():
                table.append({"density_min": lo, "density_max": None if np.isinf(hi) else hi,
                              "samples": int(m.sum()), "mean_speed_mps": float(sp[m].mean())})
        left = ~act[-1, sel] & act.any(axis=0)[sel]
        ratio = lengths[sel][l_own > 1e-6] / l_own[l_own > 1e-6]
        report[g] = {
            "agents": int(len(sel)),
            "lateral_spread_m": float(np.mean(spreads)) if spreads else 0.0,
            "lateral_deviation_m": float(np.mean(dev)) if dev else 0.0,
            "heading_change_rate_rad_s": float(turn.mean()) if turn.size else 0.0,
            "mean_speed_mps": float(speed[:-1, sel][w].mean()) if w.any() else 0.0,
            "speed_density_slope": slope,
            "speed_by_density": table,
            "mixing_index": float(np.mean(mixing[g])) if mixing[g] else None,
            "same_group_neighbors": float(np.mean(same[g])) if same[g] else None,
            "cluster_size": float(np.mean(cluster_size[g])) if cluster_size[g] else None,
            "clusters": float(np.mean(clusters[g])) if clusters[g] else None,
            "time_to_goal_s": float(np.mean((last[sel] - first[sel])[left] * traj.dt)) if left.any() else None,
            "path_length_ratio": float(ratio.mean()) if ratio.size else None,
        }
    return report


def _same_group_clusters(tree: cKDTree, code: np.ndarray, meeting: bool):
    """Connected components of same-group agents linked closer than CLUSTER_LINK: (size of
    each component, component of each agent), or (None, None) when no groups meet."""
    if not meeting:
        return None, None
    pairs = tree.query_pairs(CLUSTER_LINK, output_type="ndarray")
    pairs = pairs[code[pairs[:, 0]] == code[pairs[:, 1]]] if len(pairs) else pairs.reshape(0, 2)
    n = len(code)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return np.bincount(label), label


def edge_length_error(points: np.ndarray, rest: np.ndarray, edges: np.ndarray) -> tuple[float, float]:
    """Formation deviation: mean and max relative edge-length error of ``points`` (n, 2)
    against the ``rest`` positions over ``edges`` (m, 2): |‖p_i − p_j‖ / ‖r_i − r_j‖ − 1|."""
    if len(edges) == 0:
        return 0.0, 0.0
    cur = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1)
    ref = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
    e = np.abs(cur / ref - 1.0)
    return float(e.mean()), float(e.max())


def kabsch_rms(points: np.ndarray, template: np.ndarray) -> float:
    """Formation deviation: RMS distance from ``points`` (n, d) to ``template`` (n, d) after
    the best rotation and translation of the template (Kabsch; reflections excluded)."""
    p = points - points.mean(axis=0)
    q = template - template.mean(axis=0)
    u, _, vt = np.linalg.svd(q.T @ p)
    d = np.ones(p.shape[1])
    d[-1] = np.sign(np.linalg.det(u @ vt)) or 1.0
    rot = u @ np.diag(d) @ vt
    return float(np.sqrt(np.mean(np.sum((q @ rot - p) ** 2, axis=1))))


def diversity(runs: list[Trajectories]) -> dict:
    """How far runs of one scenario with different seeds differ (000 §3.2: the same
    starts and goal, three runs, positions compared at the same frame).

    For every pair of runs and every frame both have, the distance between each agent's
    two positions (agents present in both). Returns ``pairs`` (how many run pairs),
    ``mean_distance_m`` (over pairs, frames and agents), ``max_distance_m``,
    ``share_apart`` (the share of those agent-frames where the two positions differ by
    more than 1 mm), ``by_frame_m`` (the mean distance at each frame, a list) and
    ``first_apart_s`` (the first time any agent is apart in any pair; None if never).
    """
    if len(runs) < 2:
        raise ValueError(f"diversity needs at least two runs, got {len(runs)}")
    n = {r.n_agents for r in runs}
    if len(n) > 1:
        raise ValueError(f"diversity compares runs of one scenario: their agent counts differ ({sorted(n)})")
    dts = {r.dt for r in runs}
    if len(dts) > 1:
        raise ValueError(f"diversity compares frames at the same times: the runs' time steps differ ({sorted(dts)})")
    t = min(r.n_frames for r in runs)
    sums = np.zeros(t)
    counts = np.zeros(t)
    worst, apart, total, first = 0.0, 0, 0, None
    for i in range(len(runs)):
        for j in range(i + 1, len(runs)):
            a, b = runs[i], runs[j]
            d = np.linalg.norm(a.positions[:t] - b.positions[:t], axis=-1)
            both = a.active_mask[:t] & b.active_mask[:t]
            d = np.where(both, d, 0.0)
            sums += d.sum(axis=1)
            counts += both.sum(axis=1)
            worst = max(worst, float(d.max()))
            far = (d > 1e-3) & both
            apart += int(far.sum())
            total += int(both.sum())
            if far.any():
                f = int(np.flatnonzero(far.any(axis=1))[0])
                first = f if first is None else min(first, f)
    by_frame = np.divide(sums, counts, out=np.zeros(t), where=counts > 0)
    return {"pairs": len(runs) * (len(runs) - 1) // 2, "mean_distance_m": float(sums.sum() / max(counts.sum(), 1)),
            "max_distance_m": worst, "share_apart": apart / max(total, 1), "by_frame_m": by_frame.tolist(),
            "first_apart_s": None if first is None else first * runs[0].dt}


def note_step_limit(summary: dict, setting: str, value: int, at_limit: bool, seconds: float,
                    short: bool | None = None, stalled: int = 0) -> None:
    """Record in ``summary["ended_at_limit"]`` that the run stopped at its step limit (the
    scenario's ``setting`` = ``value``, ``seconds`` of simulated time: ``at_limit``) with
    agents still short of their goals (``short``; default: not everyone arrived): they did
    not fail to arrive, the run ended. Nothing when everyone arrived or the run stopped
    sooner (interrupted, or done). ``stalled``: how many of those short had stopped
    getting anywhere (:func:`stalled_short`), for whom more steps would not help."""
    if short is None:
        short = summary.get("arrival_rate", 1.0) < 1.0
    if at_limit and short:
        summary["ended_at_limit"] = {"setting": setting, "value": int(value), "simulated_s": float(seconds),
                                     **({"stalled": int(stalled)} if stalled else {})}


STALLED_SHARE = 0.25  # the last quarter of a run ...
STALLED_M = 0.5  # ... in which an agent short of its goal got no nearer than this


def stalled_short(traj: Trajectories, goals: np.ndarray, arrived: np.ndarray) -> int:
    """How many agents that did not arrive (``arrived`` False; ``goals`` (N, dim) their
    goal points) came no nearer their goal than STALLED_M over the last STALLED_SHARE of
    the run's frames while in the scene: stuck (behind a wall, say), not slow."""
    short = np.flatnonzero(~np.asarray(arrived, dtype=bool))
    if not len(short) or traj.n_frames < 4:
        return 0
    start = int(traj.n_frames * (1.0 - STALLED_SHARE))
    p, act = traj.positions[start:, short], traj.active_mask[start:, short]
    d = np.linalg.norm(p - np.asarray(goals, dtype=float)[short][None], axis=-1)
    there = act.any(axis=0)
    first = d[np.argmax(act, axis=0), np.arange(len(short))]
    best = np.where(act, d, np.inf).min(axis=0)
    return int(np.sum(there & (first - best < STALLED_M)))


def headline(summary: dict) -> str:
    """A run's summary in one line: agents, frames, the audit, arrivals, formations."""
    parts = [f"{summary['agents']} agents", f"{summary['frames']} frames",
             f"agent overlaps {summary['agent_agent_overlaps']}",
             f"obstacle penetrations {summary['agent_obstacle_penetrations']}"]
    if "arrival_rate" in summary:
        parts.append(f"arrived {summary['arrival_rate']:.0%}")
        if summary.get("ended_at_limit"):
            stayed = summary.get("journeys", {}).get("standing_at_end", 0)
            if stayed:  # a route with no leave: those done stand at its last place, perhaps in the way
                parts[-1] += (f" ({_stopped_at(summary)} before the rest got there; {stayed} finished a route that "
                              f"does not leave and stand at its last place, perhaps in the others' way: end the "
                              f"route with a leave stage, or raise the setting)")
            elif summary["ended_at_limit"].get("stalled"):
                n = summary["ended_at_limit"]["stalled"]
                parts[-1] += (f" ({_stopped_at(summary)} with {n} short of their goal that came no nearer it in the "
                              f"run's last quarter: stuck, an obstacle in the way perhaps: more steps will not "
                              f"bring them)")
            else:
                parts[-1] += f" ({_stopped_at(summary)} before the rest got there: raise it to let them arrive)"
    if "formation" in summary:
        groups = summary["formation"]
        done = sum(g["recovered_s"] is not None for g in groups.values())
        worst = max(g["edge_length_error_mean"] for g in groups.values())
        parts.append(f"formations recovered {done}/{len(groups)} (edge-length error {worst:.1%})")
        turned = {n: g["orientation_error_deg"] for n, g in groups.items()
                  if g.get("orientation_error_deg") is not None and g["orientation_error_deg"] > ORIENTATION_NOTE_DEG}
        if turned:  # in its shape, but not facing the way it should (its given heading, or its route's last leg)
            n, deg = max(turned.items(), key=lambda kv: kv[1])
            parts[-1] += f", {len(turned)} turned off the way it should face ({n!r} {deg:.0f}°)"
        if summary.get("ended_at_limit") and "arrival_rate" not in summary:
            parts[-1] += (f"; {_stopped_at(summary)} before every formation had recovered: raise it, or give them "
                          f"room to re-form at their goals")
    return ", ".join(parts)


def _stopped_at(summary: dict) -> str:
    """``the run stopped at rvo.max_steps = 400, 100 s simulated,`` from ``ended_at_limit``."""
    limit = summary["ended_at_limit"]
    return f"the run stopped at {limit['setting']} = {limit['value']}, {limit['simulated_s']:g} s simulated,"
