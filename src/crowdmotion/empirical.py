"""Real crowds as the yardstick: the published measurements a crowd researcher judges a
model against, the experiments' set-ups rebuilt as scenes, and the measures the
experimenters used (``crowdmotion verify --empirical``).

Each case is a :class:`crowdmotion.cases.Case`: it builds its runs (several seeds
each), runs them through the same registry as ``crowdmotion run``, and judges them with
its own tolerance against the data below (sources in docs/verification.md and
shared data file ``empirical-references.md``):

- **Speed against density**: the FZJ/Hermes 2009 open-corridor protocol (holding area,
  entrance b_in, a 1.8 m × 8 m corridor, exit b_out), classical density and mean speed
  in a 2 m measurement area over the run's stationary part, against Weidmann's (1993)
  curve and the FZJ closed-corridor runs (Zhang et al. 2011).
- **Bottleneck flow against width**: JuPedSim's encoding of the Kretz 2006, Seyfried
  2009 and FZJ/Wuppertal 2006 experiments (10 × 8 m room, 2 m long bottleneck, 200
  persons of radius 0.2 m, v0 1.34 m/s), the flow over the stationary part of the N–t
  curve (10 %–90 %).
- **Counterflow**: the FZJ BOT-360 runs (3.6 m × 8 m corridor, both streams entering at
  its ends through entrances of width b and leaving sideways at the far end; JuPedSim's
  7test_BO geometry), mean speed in the measurement area against the run at the nearest
  density, and the lane order against shuffled directions. The runs as they were
  measured (the FZJ data archive's trajectory files) are read into the same corridor by
  :func:`fzj_bot_trajectories`, so the same measures apply to people and to the model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crowdmotion.groups import Group, Rect
from crowdmotion.rvo.density import speed_share, weidmann_speed
from crowdmotion.scene import Box, Scene
from crowdmotion.trajectories import Trajectories
from crowdmotion.cases import Case, Outcome, Setup, crossing_times, stationary

SEEDS = (0, 1, 2)
RADIUS = 0.2

#: FZJ/Hermes 2009 closed corridor 1.8 m ("UG"), mean (ρ /m², v m/s) of each run (Zhang et al. 2011)
UG_RUNS = ((0.30, 1.14), (0.58, 1.01), (1.18, 0.78), (1.52, 0.53), (1.85, 0.54), (2.42, 0.36), (3.30, 0.22),
           (3.98, 0.11))
#: bottleneck width (m) -> measured flows (persons/s): Kretz et al. 2006, Seyfried et al. 2009, FZJ/Wuppertal 2006
BOTTLENECK_FLOWS = {
    0.8: (1.388, 1.417, 1.456, 1.288), 0.9: (1.534, 1.583, 1.632, 1.674, 1.593),
    1.0: (1.710, 1.808, 1.876, 2.023, 1.900, 1.832), 1.1: (2.123, 1.988), 1.2: (2.033, 2.111, 2.287, 2.364, 2.312),
    1.4: (2.706,), 1.6: (2.842,), 1.8: (3.551,), 2.0: (3.549,), 2.2: (4.063,), 2.5: (5.116,)}
#: FZJ BOT-360 runs, mean (ρ /m², v m/s) per run (Zhang et al. 2012)
BOT_360_RUNS = ((0.45, 1.52), (0.67, 1.31), (0.99, 1.18), (1.61, 0.85), (2.25, 0.56), (2.56, 0.53))
#: the BOT-360 runs' own lane order over its value with the directions shuffled, at their
#: density (persons/m²): the FZJ trajectories (OpenTraj datasets/HERMES/Corridor-2D,
#: bot-360-050 … 250) measured by :func:`bot_measures` through :func:`fzj_bot_trajectories`
BOT_360_LANE_RATIOS = ((0.39, 1.07), (0.61, 1.24), (0.91, 1.32), (1.47, 1.72), (2.00, 2.23), (2.46, 2.71),
                       (2.50, 2.80))
#: BOT-360 entrance widths (m) and persons per side (OpenTraj's HERMES README)
BOT_360_SETUPS = ((0.5, 50), (0.75, 50), (0.9, 100), (1.2, 100), (1.6, 150), (2.0, 150), (2.5, 150))
#: Weidmann's free walking speed (m/s) and the half-width of the uniform spread round it
FREE_SPEED, SPEED_SPREAD = 1.34, 0.24
#: the BOT-360 participants' free speed (m/s): their run at the lowest density (1.52 m/s at
#: 0.45 /m²) over the share of the free speed the density-speed relation leaves there
#: (rvo.density.speed_share): 1.58 m/s, where Weidmann's walkers would walk 1.30 there
BOT_FREE_SPEED = BOT_360_RUNS[0][1] / float(speed_share(BOT_360_RUNS[0][0]))
#: a walker's top speed above its top preferred speed
SPEED_HEADROOM = 0.22


def _walkers(name: str, count: int, spawn: Rect, goal: Rect, free: float = FREE_SPEED, **kw) -> Group:
    """Adults walking at free speeds drawn uniformly from ``free`` ± SPEED_SPREAD (Weidmann's
    1.34 m/s: 1.1–1.58 m/s), at most SPEED_HEADROOM faster than the fastest of them."""
    low, high = round(free - SPEED_SPREAD, 2), round(free + SPEED_SPREAD, 2)
    return Group(name, count, spawn=spawn, goal=goal, radius=RADIUS, max_speed=round(high + SPEED_HEADROOM, 2),
                 pref_speed=round(free, 2), attributes={"pref_speed_range": [low, high]}, **kw)


def _params(method: str, **extra) -> dict:
    return {"max_steps": 4000, "spawn_gap": 0.02, **extra} if method == "rvo" else {"max_steps": 4000}


# ---- measures ----------------------------------------------------------------------------------
def area_density_speed(traj: Trajectories, lower, upper, start: float, end: float) -> tuple[float, float]:
    """Classical density (persons/m²) and mean speed (m/s, central differences) in the
    rectangle ``lower``–``upper``, averaged over the frames between ``start`` and ``end`` s."""
    p, act, dt = traj.positions, traj.active_mask, traj.dt
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    inside = act & np.all((p >= lo) & (p <= hi), axis=2)
    frames = np.arange(1, traj.n_frames - 1)
    frames = frames[(frames * dt >= start) & (frames * dt <= end)]
    if len(frames) == 0:
        return float("nan"), float("nan")
    speed = np.linalg.norm(p[frames + 1] - p[frames - 1], axis=2) / (2 * dt)
    ok = inside[frames] & inside[frames - 1] & inside[frames + 1]
    area = float(np.prod(hi - lo))
    return float(inside[frames].sum(axis=1).mean() / area), float(speed[ok].mean()) if ok.any() else float("nan")


def lane_order(points: np.ndarray, direction: np.ndarray, ahead: float = 2.0, side: float = 0.3) -> float:
    """Mean over the agents of ((same − opposite) / (same + opposite))², counting the
    neighbours within ``ahead`` metres along the corridor (x) and ``side`` metres across
    it; 1 in perfect lanes, near 0 when the two directions are mixed (agents without
    neighbours left out; NaN if none has any)."""
    d = points[None] - points[:, None]
    near = (np.abs(d[..., 0]) <= ahead) & (np.abs(d[..., 1]) <= side)
    np.fill_diagonal(near, False)
    same_dir = direction[None] == direction[:, None]
    same, opposite = (near & same_dir).sum(axis=1), (near & ~same_dir).sum(axis=1)
    total = same + opposite
    ok = total > 0
    return float(np.mean(((same - opposite)[ok] / total[ok]) ** 2)) if ok.any() else float("nan")


def _within(measured: float, reference: float, absolute: float, relative: float) -> bool:
    return bool(np.isfinite(measured) and abs(measured - reference) <= max(absolute, relative * abs(reference)))


def _everyone_left(outcomes: dict[str, Outcome]) -> bool:
    return all(float(o.summary.get("arrival_rate", 0.0)) == 1.0 for o in outcomes.values())


def _seeded(builder, seeds=SEEDS):
    """A case builder running every set-up of ``builder`` once per seed (keys 'name/seed')."""
    def build(method: str) -> dict[str, Setup]:
        return {f"{name}/{s}": Setup(st.scene, st.groups, st.params, seed=s)
                for name, st in builder(method).items() for s in seeds}
    return build


# ---- speed against density: the FZJ open corridor ----------------------------------------------
#: (b_in, b_out, persons): entrance and exit widths of the UO-180 runs' range
UO_RUNS = ((1.0, 1.8, 150), (1.8, 1.8, 200), (1.8, 1.0, 200), (1.8, 0.7, 200))
UO_AREA = ((13.0, 3.1), (15.0, 4.9))  # 2 m of the corridor's middle


def open_corridor(b_in: float, b_out: float) -> Scene:
    """A 12 × 8 m holding area (x −4–8), an entrance of ``b_in``, a 1.8 m × 8 m corridor
    (x 10–18), an exit of ``b_out`` and 12 m of open ground."""
    cy = 4.0
    return Scene(bounds=([-4, 0], [30, 8]), obstacles=[
        Box([8, 0], [10, cy - b_in / 2]), Box([8, cy + b_in / 2], [10, 8]),
        Box([10, 0], [18, cy - 0.9]), Box([10, cy + 0.9], [18, 8]),
        Box([18, 0], [18.2, cy - b_out / 2]), Box([18, cy + b_out / 2], [18.2, 8])])


def _uo(method: str) -> dict[str, Setup]:
    return {f"UO b_in {bi:g} b_out {bo:g}": Setup(
        open_corridor(bi, bo), [_walkers("walkers", n, Rect([-3.7, 0.3], [7.7, 7.7]), Rect([27, 0.5], [29.5, 7.5]))],
        _params(method)) for bi, bo, n in UO_RUNS}


def uo_points(outcomes: dict[str, Outcome]) -> list[tuple[str, float, float]]:
    """(run, density, speed) of each open-corridor run, the means over its seeds."""
    per_run: dict[str, list[tuple[float, float]]] = {}
    for name, o in outcomes.items():
        start, end, _ = stationary(crossing_times(o.traj, 0, 18.2))
        per_run.setdefault(name.split("/")[0], []).append(area_density_speed(o.traj, *UO_AREA, start, end))
    return [(run, *np.mean(points, axis=0)) for run, points in per_run.items()]


def _judge_uo(outcomes: dict[str, Outcome]) -> tuple[str, str, bool]:
    ok, parts = _everyone_left(outcomes), []
    for name, rho, v in uo_points(outcomes):
        w = float(weidmann_speed(rho))
        ug = min(UG_RUNS, key=lambda r: abs(r[0] - rho))
        good = _within(v, w, 0.15, 0.3) and _within(v, ug[1], 0.15, 0.3)
        ok &= good
        parts.append(f"{name}: {rho:.2f}/m² {v:.2f} m/s (Weidmann {w:.2f}, FZJ {ug[1]:.2f}){'' if good else ' ✗'}")
    return ("in each run (mean of its seeds), the speed at its density within ±0.15 m/s or ±30 % of Weidmann's "
            "curve and of the nearest FZJ corridor run; everyone leaves", "; ".join(parts), bool(ok))


# ---- bottleneck flow against width -------------------------------------------------------------
BOTTLENECK_WIDTHS = (0.8, 1.0, 1.2, 1.6, 2.0, 2.5)


def bottleneck(width: float) -> Scene:
    """A 10 × 8 m room (x 0–10), a ``width`` wide, 2 m long bottleneck (x 10–12), 8 m outside."""
    return Scene(bounds=([0, 0], [20, 8]), obstacles=[Box([10, 0], [12, 4 - width / 2]),
                                                      Box([10, 4 + width / 2], [12, 8])])


def _bottleneck(method: str) -> dict[str, Setup]:
    return {f"b {b:g}": Setup(bottleneck(b), [Group("room", 200, spawn=Rect([0.3, 0.3], [9.7, 7.7]),
                                                    goal=Rect([17, 0.5], [19.5, 7.5]), radius=RADIUS,
                                                    max_speed=1.6, pref_speed=1.34)], _params(method))
            for b in BOTTLENECK_WIDTHS}


def bottleneck_flows(outcomes: dict[str, Outcome]) -> dict[float, float]:
    """Width -> mean stationary flow (persons/s) at the bottleneck's exit over the seeds."""
    flows: dict[float, list[float]] = {}
    for name, o in outcomes.items():
        width = float(name.split("/")[0].split()[1])
        flows.setdefault(width, []).append(stationary(crossing_times(o.traj, 0, 12.0))[2])
    return {b: float(np.mean(f)) for b, f in sorted(flows.items())}


def _judge_bottleneck(outcomes: dict[str, Outcome]) -> tuple[str, str, bool]:
    flows = bottleneck_flows(outcomes)
    ok, parts = _everyone_left(outcomes), []
    for b, j in flows.items():
        ref = float(np.mean(BOTTLENECK_FLOWS[b]))
        good = _within(j, ref, 0.0, 0.25)
        ok &= good
        parts.append(f"{b:g} m: {j:.2f}/s (data {ref:.2f}){'' if good else ' ✗'}")
    growing = all(a < b for a, b in zip(list(flows.values()), list(flows.values())[1:]))
    return ("flow at each width within ±25 % of the experiments' mean, growing with width; everyone leaves",
            "; ".join(parts), bool(ok and growing))


# ---- a narrow door: Kretz et al. 2006 -------------------------------------------------------------
DOOR_WIDTH_M = 0.7
DOOR_MIN_FLOW = 1.0   # persons/s the issue asks of a 0.7 m door (Kretz et al. measured about 1.2)
DOOR_CROWD = Rect([3.8, 0.2], [9.8, 7.8])  # 148 persons at 3.2 /m² pressed up to the door
DOOR_SEEDS = range(5)  # an arch in the mouth that stands for a minute swings one run's flow by a quarter


def longest_wait(times: np.ndarray) -> float:
    """The longest time between two successive crossings (s; NaN with fewer than two):
    how long a door stood still at worst, which the stationary flow averages away."""
    t = np.sort(times[np.isfinite(times)])
    return float(np.diff(t).max()) if len(t) > 1 else float("nan")


def _narrow_door(method: str) -> dict[str, Setup]:
    return {f"door {DOOR_WIDTH_M:g}": Setup(bottleneck(DOOR_WIDTH_M), [
        Group("room", 148, spawn=DOOR_CROWD, goal=Rect([17, 0.5], [19.5, 7.5]), radius=RADIUS, max_speed=1.6,
              pref_speed=1.34)], _params(method))}


def _judge_narrow_door(outcomes: dict[str, Outcome]) -> tuple[str, str, bool]:
    times = [crossing_times(o.traj, 0, 12.0) for o in outcomes.values()]
    flows = [stationary(t)[2] for t in times]
    mean = float(np.mean(flows))
    waits = ", ".join(f"{longest_wait(t):.1f}" for t in times)
    return (f"everyone leaves; the stationary flow through the {DOOR_WIDTH_M:g} m door, mean of the seeds, at least "
            f"{DOOR_MIN_FLOW:g} /s (Kretz et al.: about 1.2 /s)",
            f"{mean:.2f} /s (seeds {', '.join(f'{f:.2f}' for f in flows)}); longest wait between two passing: "
            f"{waits} s",
            bool(_everyone_left(outcomes) and mean >= DOOR_MIN_FLOW))


# ---- counterflow: the FZJ BOT-360 corridor -------------------------------------------------------
BOT_AREA = ((12.0, 0.0), (14.0, 3.6))  # 2 m of the corridor's middle


def bot_corridor(width: float) -> Scene:
    """JuPedSim's 7test_BO layout turned to run along x: a 3.6 m × 8 m corridor (x 9–17),
    at each end a 3.8 m gap open to both sides, then a holding area (8 × 8 m) behind a
    wall with an entrance of ``width`` in line with the corridor."""
    w, cy = 3.6, 1.8
    return Scene(bounds=([-3, -4], [29, 7.6]), obstacles=[
        Box([9, -4], [17, 0]), Box([9, w], [17, 7.6]),
        Box([-3, -4], [5.2, -2.2]), Box([-3, 5.8], [5.2, 7.6]),
        Box([20.8, -4], [29, -2.2]), Box([20.8, 5.8], [29, 7.6]),
        Box([5, -2.2], [5.2, cy - width / 2]), Box([5, cy + width / 2], [5.2, 5.8]),
        Box([20.8, -2.2], [21, cy - width / 2]), Box([20.8, cy + width / 2], [21, 5.8])])


#: the BOT-360 walkers look again every this many seconds which side exit is nearer where
#: they walk, and take it (``Choose(by="nearest", rechoose=...)``, no margin): the people
#: left by the exit on the side they walked (bot_exit_sides)
BOT_RECHOOSE_S = 1.0


def bot_exits(gap: tuple[float, float]) -> list[Rect]:
    """The two side exits (south, north) of the gap at a BOT-360 corridor's far end
    spanning x ``gap``."""
    return [Rect([gap[0], -3.7], [gap[1], -2.5]), Rect([gap[0], 6.1], [gap[1], 7.3])]


def _bot(method: str) -> dict[str, Setup]:
    from crowdmotion.stages import Choose, Leave

    out = {}
    for b, n in BOT_360_SETUPS[2::2]:  # 0.9, 1.6, 2.5 m: low, middle and high density
        groups = []
        for name, spawn, gap in (("east", Rect([-2.7, -1.9], [4.7, 5.5]), (17.4, 20.4)),
                                 ("west", Rect([21.3, -1.9], [28.7, 5.5]), (5.6, 8.6))):
            # each leaves by the side exit of the far gap nearer where it walks
            exits = bot_exits(gap)
            g = _walkers(name, n, spawn, exits[0], free=BOT_FREE_SPEED)
            g.attributes["route"] = [Choose([Leave(e) for e in exits], "nearest", rechoose=BOT_RECHOOSE_S,
                                            rechoose_margin=0.0)]
            groups.append(g)
        out[f"BOT b {b:g}"] = Setup(bot_corridor(b), groups, _params(method, max_steps=2400))
    return out


def bot_exit_sides(traj: Trajectories) -> tuple[float, float]:
    """(share of the walkers on the same side of a BOT-360 corridor's centre line 0.2 m
    before its far end as 3 m into it, correlation of the two lateral offsets): how far
    the walkers keep to the corridor's end the side they walk in it (the side exits lie
    beyond that end). The people of the measured runs: 0.82-0.95 and 0.81-0.92."""
    east = np.char.startswith(traj.group.astype(str), "east")
    x, y = traj.positions[..., 0], traj.positions[..., 1]
    mid, end = [], []
    for i in range(traj.n_agents):
        into = np.where(traj.active_mask[:, i], x[:, i] - 9.0 if east[i] else 17.0 - x[:, i], np.nan)
        seen = np.flatnonzero(np.isfinite(into))
        at_mid, at_end = np.flatnonzero(into >= 3.0), np.flatnonzero(into >= 7.8)
        if len(at_mid) and len(at_end) and into[seen[0]] < 3.0:  # walked the corridor from before 3 m in
            mid.append(y[at_mid[0], i] - 1.8)
            end.append(y[at_end[0], i] - 1.8)
    if len(mid) < 2:
        return float("nan"), float("nan")
    mid, end = np.array(mid), np.array(end)
    return float(np.mean(np.sign(mid) == np.sign(end))), float(np.corrcoef(mid, end)[0, 1])


def _bot_frames(traj: Trajectories) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N,) walkers bound east, (T, N) walkers in BOT_AREA, (T,) the frames measured: those
    holding at least half the area's fullest count."""
    east = np.char.startswith(traj.group.astype(str), "east")
    inside = traj.active_mask & np.all((traj.positions >= BOT_AREA[0]) & (traj.positions <= BOT_AREA[1]), axis=2)
    return east, inside, inside.sum(axis=1) >= 0.5 * inside.sum(axis=1).max()


def bot_measures(traj: Trajectories, rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(density, speed, lane order, lane order with the directions shuffled) of a BOT-360
    run: density and speed in BOT_AREA over the frames holding at least half its most
    crowded frame's count, the lane orders in the corridor (x 10-16) every fourth of them."""
    east, inside, busy = _bot_frames(traj)
    start, end = np.flatnonzero(busy)[[0, -1]] * traj.dt if busy.any() else (0.0, 0.0)
    rho, v = area_density_speed(traj, *BOT_AREA, start, end)
    corridor = traj.active_mask & (traj.positions[..., 0] >= 10) & (traj.positions[..., 0] <= 16)
    lanes, shuffled = [], []
    for f in np.flatnonzero(busy)[::4]:
        idx = np.flatnonzero(corridor[f])
        if len(idx) >= 6:
            lanes.append(lane_order(traj.positions[f, idx], east[idx]))
            shuffled.append(lane_order(traj.positions[f, idx], rng.permutation(east[idx])))
    mean = lambda x: float(np.nanmean(x)) if x else float("nan")  # noqa: E731
    return rho, v, mean(lanes), mean(shuffled)


#: a walker "meets" an oncoming one within this far ahead (m) and this far across (m): the
#: two must step aside to pass (two bodies are about 0.45 m wide)
PASS_AHEAD_M, PASS_SIDE_M = 1.5, 0.5
#: slower than this along its way (m/s), a walker meeting an oncoming one has stopped for it
PASS_STOPPED = 0.2


@dataclass(frozen=True)
class Passing:
    """How walkers pass the oncoming stream in a BOT-360 run (:func:`bot_passing`)."""

    meeting: float    # share of the moments at which a walker meets an oncoming one
    speed_meeting: float  # mean speed along its own way while it meets one (m/s)
    speed_others: float   # the same at the other moments
    stopped: float    # share of the meeting moments spent slower than PASS_STOPPED along its way
    backwards: float  # share of all moments walking against its own way


def bot_passing(traj: Trajectories) -> Passing:
    """How the walkers in a BOT-360 run's measurement area pass the oncoming stream, over
    the frames :func:`bot_measures` measures (those holding at least half the area's
    fullest count): at each frame each walker there either *meets* an oncoming one (within
    ``PASS_AHEAD_M`` ahead along the corridor and ``PASS_SIDE_M`` across: one of the two
    must step aside) or not; its speed is its velocity along its own way (east or west),
    by central differences between frames."""
    east, inside, busy = _bot_frames(traj)
    way = np.where(east, 1.0, -1.0)
    along = np.gradient(traj.positions[..., 0], traj.dt, axis=0) * way
    meets, speeds = [], []
    for f in np.flatnonzero(busy):
        here, present = np.flatnonzero(inside[f]), np.flatnonzero(traj.active_mask[f])
        d = traj.positions[f, present][None] - traj.positions[f, here][:, None]  # (here, present, 2)
        ahead = d[..., 0] * way[here][:, None]
        oncoming = way[present][None] != way[here][:, None]
        meets.append(np.any(oncoming & (ahead > 0) & (ahead <= PASS_AHEAD_M) & (np.abs(d[..., 1]) <= PASS_SIDE_M),
                            axis=1))
        speeds.append(along[f, here])
    if not meets:
        return Passing(*(float("nan"),) * 5)
    meet, v = np.concatenate(meets), np.concatenate(speeds)
    mean = lambda x: float(x.mean()) if len(x) else float("nan")  # noqa: E731
    return Passing(float(meet.mean()), mean(v[meet]), mean(v[~meet]), mean(v[meet] < PASS_STOPPED), float(np.mean(v < 0)))


#: frames per second of the FZJ trajectory files (the data archive's text format)
FZJ_FPS = 16


def fzj_bot_trajectories(path, step: float = 0.25) -> Trajectories:
    """A BOT-360 run as it was measured: the FZJ data archive's trajectory file (as
    OpenTraj ships them, ``datasets/HERMES/Corridor-2D/bot-360-*.txt``: one row per
    person and frame, ``ID FRAME X Y Z`` in cm at 16 frames/s, the corridor along Y
    from -400 to 400 and across X from 0 to 360) placed in :func:`bot_corridor`'s frame
    (along x, the corridor x 9–17 and y 0–3.6) and sampled every ``step`` seconds, as a
    run's frames are, so :func:`bot_measures` measures the people with the same code as
    the model. Each person is "east" or "west" by the way they walked."""
    from pathlib import Path

    path = Path(path)
    try:
        rows = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not an FZJ trajectory file (rows of ID FRAME X Y Z): {exc}") from None
    if rows.shape[1] < 4 or len(rows) == 0 or not np.isfinite(rows[:, :4]).all():
        raise ValueError(f"{path}: not an FZJ trajectory file: need rows of ID FRAME X Y Z, finite numbers, "
                         f"got {rows.shape[1]} columns")
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a positive number of seconds, got {step!r}")
    every = max(1, int(round(step * FZJ_FPS)))
    rows = rows[rows[:, 1].astype(np.int64) % every == 0]
    person = np.unique(rows[:, 0].astype(np.int64), return_inverse=True)[1]
    frame = rows[:, 1].astype(np.int64) // every
    frame -= frame.min()
    positions = np.zeros((frame.max() + 1, person.max() + 1, 2))
    active = np.zeros(positions.shape[:2], dtype=bool)
    positions[frame, person] = np.stack([rows[:, 3] / 100.0 + 13.0, rows[:, 2] / 100.0], axis=1)
    active[frame, person] = True
    first, last = active.argmax(axis=0), active.shape[0] - 1 - active[::-1].argmax(axis=0)
    people = np.arange(positions.shape[1])
    east = positions[last, people, 0] > positions[first, people, 0]
    return Trajectories(positions, every / FZJ_FPS, group=np.where(east, "east", "west"), radius=RADIUS,
                        active=active, metadata={"source": str(path)})


def _judge_bot(outcomes: dict[str, Outcome]) -> tuple[str, str, bool]:
    ok, parts = _everyone_left(outcomes), []
    rng = np.random.default_rng(0)
    for name, o in outcomes.items():
        rho, v, order, base = bot_measures(o.traj, rng)
        ref = min(BOT_360_RUNS, key=lambda r: abs(r[0] - rho))
        real = min(BOT_360_LANE_RATIOS, key=lambda r: abs(r[0] - rho))
        good = _within(v, ref[1], 0.2, 0.0) and order >= 2 * base and o.summary.get("arrival_rate") == 1.0
        ok &= good
        parts.append(f"{name}: {rho:.2f}/m² {v:.2f} m/s (FZJ {ref[1]:.2f}), lanes {order:.2f} vs {base:.2f} shuffled "
                     f"({order / base:.2f}x; FZJ at {real[0]:.2f}/m² {real[1]:.2f}x), "
                     f"{o.summary.get('arrival_rate', 0):.0%} out{'' if good else ' ✗'}")
    return ("everyone leaves; speed within ±0.2 m/s of the run at the nearest density; lane order at least twice "
            "its value with the directions shuffled", "; ".join(parts), bool(ok))


CASES: list[Case] = [
    Case("fd_open_corridor", "FZJ/Hermes UO-180; Weidmann 1993; Zhang et al. 2011",
         "speed against density in a 1.8 m corridor behind exits of 1.8-0.7 m", ("rvo",), _seeded(_uo), _judge_uo),
    Case("bottleneck_flow", "Kretz et al. 2006; Seyfried et al. 2009; FZJ/Wuppertal 2006",
         "200 persons leave a 10 x 8 m room through a 2 m long bottleneck of 0.8-2.5 m", ("rvo",),
         _seeded(_bottleneck), _judge_bottleneck),
    Case("narrow_door", "Kretz, Grünebohm & Schreckenberg 2006",
         "148 persons at 3.2 /m² leave through a 0.7 m wide, 2 m long door", ("rvo",),
         _seeded(_narrow_door, DOOR_SEEDS),
         _judge_narrow_door),
    Case("counterflow_lanes", "FZJ/Hermes BOT-360 (Zhang et al. 2012)",
         "two streams of 100-150 meet in a 3.6 m corridor", ("rvo",), _seeded(_bot), _judge_bot),
]
