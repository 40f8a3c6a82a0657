"""JuPedSim's pedestrian models on crowdmotion's empirical suite.

Runs JuPedSim 1.4's Collision-Free Speed Model ("csm"), Anticipation Velocity Model
("avm") and Social Force Model ("sfm") at their documented default parameters and
default time step (0.01 s) on the geometries of :mod:`crowdmotion.empirical` (the FZJ
open corridor, the bottleneck and the BOT-360 counterflow), with the same spawn positions,
desired speeds and radius (0.2 m) crowdmotion uses, and measures the runs with the suite's
own measures (``stationary``, ``area_density_speed``, ``crossing_times``,
``bot_measures``), so the numbers sit beside crowdmotion's and the data::

    python benchmarks/empirical_jupedsim.py --seeds 1 --models csm avm sfm --cases bottleneck corridor counterflow
"""

from __future__ import annotations

import argparse
import time

import jupedsim as jps
import numpy as np
from shapely.geometry import box
from shapely.ops import unary_union

from crowdmotion import empirical
from crowdmotion.empirical import (BOTTLENECK_FLOWS, BOTTLENECK_WIDTHS, UG_RUNS, UO_AREA, UO_RUNS, area_density_speed,
                                   stationary)
from crowdmotion.groups import Rect
from crowdmotion.placement import spawn_positions
from crowdmotion.routing import distance_fields
from crowdmotion.rvo.density import weidmann_speed
from crowdmotion.scene import Box, Scene
from crowdmotion.trajectories import Trajectories
from crowdmotion.verify import crossing_times

MODELS = ("csm", "avm", "sfm")
MODEL_NAMES = {"csm": "CollisionFreeSpeedModel", "avm": "AnticipationVelocityModel", "sfm": "SocialForceModel"}
DT = 0.01  # JuPedSim's default time step
RECORD_EVERY = 25  # iterations between recorded frames: 0.25 s
RADIUS = 0.2
SPAWN_GAP = 0.02
MAX_TIME_S = {"bottleneck": 400.0, "corridor": 400.0, "counterflow": 600.0}  # crowdmotion's: 4000 / 2400 steps
FREEZE_S, FREEZE_M = 60.0, 0.05  # a run stops early once no agent has moved FREEZE_M in FREEZE_S seconds


def walkable_area(scene: Scene):
    """The scene's bounds minus its (static, 2D) Box obstacles, as a shapely polygon."""
    (x0, y0), (x1, y1) = scene.bounds
    walls = []
    for ob in scene.obstacles:
        if not isinstance(ob, Box) or ob.is_moving or ob.dim != 2:
            raise ValueError(f"only static 2D Box obstacles can be turned into JuPedSim geometry, got {ob!r}")
        walls.append(box(*ob.lower, *ob.upper))
    return box(x0, y0, x1, y1).difference(unary_union(walls)) if walls else box(x0, y0, x1, y1)


def _model(model_name: str, seed: int):
    """The model at its defaults; the AVM's internal rng (used against freezing) is seeded
    with the run's seed, since its default seed is drawn afresh at every import."""
    if model_name == "csm":
        return jps.CollisionFreeSpeedModel()
    if model_name == "avm":
        return jps.AnticipationVelocityModel(rng_seed=seed)
    if model_name == "sfm":
        return jps.SocialForceModel()
    raise ValueError(f"unknown model {model_name!r}; choose from {MODELS}")


def _agent_parameters(model_name: str, position, speed: float, journey_id: int, stage_id: int):
    """The model's agent parameters at their defaults, except position, desired speed,
    radius and the journey."""
    kw = dict(position=(float(position[0]), float(position[1])), desired_speed=float(speed), radius=RADIUS,
              journey_id=journey_id, stage_id=stage_id)
    if model_name == "csm":
        return jps.CollisionFreeSpeedModelAgentParameters(**kw)
    if model_name == "avm":
        return jps.AnticipationVelocityModelAgentParameters(**kw)
    return jps.SocialForceModelAgentParameters(**kw)


def _rect_polygon(rect: Rect):
    return box(*rect.lower, *rect.upper)


def _exits(group) -> tuple[list[Rect], tuple[float, float] | None]:
    """The exit areas of a group (its goal; or the leave stages of a route that is one
    choose by nearest among leaves, as the BOT-360 case writes its side exits) and, for
    such a route, (rechoose seconds, margin seconds)."""
    route = group.attributes.get("route") if group.attributes else None
    if route is None:
        return [group.goal], None
    from crowdmotion.stages import Choose, Leave

    st = route[0] if len(route) == 1 else None
    if not (isinstance(st, Choose) and st.by == "nearest" and all(isinstance(o, Leave) for o in st.among)):
        raise ValueError(f"group {group.name!r}: only a route of one choose by nearest among leave stages can be "
                         f"given to JuPedSim here, got {route!r}")
    return [o.area for o in st.among], (st.rechoose or np.inf, st.rechoose_margin)


def _walking(fields, points: np.ndarray) -> np.ndarray:
    """(K, m) metres from each of ``points`` to each exit, round the walls."""
    return np.column_stack([fields.nearby(k, points) for k in range(len(fields.goal_cells))])


def _rechoose(sim, choosers, taken: dict, ids: list, active: np.ndarray, positions: np.ndarray, t: float) -> None:
    """Every ``rechoose`` seconds (on the recorded frames), each agent of a choosing group
    still in switches to the exit nearer by more than ``margin`` seconds of its walking:
    crowdmotion's ``Choose(by="nearest", rechoose=...)`` (journeys), done with JuPedSim's
    ``switch_agent_journey``."""
    for members, options, fields, speeds, every, margin in choosers:
        if not np.isfinite(every) or round(t / (RECORD_EVERY * DT)) % max(1, round(every / (RECORD_EVERY * DT))):
            continue
        inside = members[active[members]]
        if not len(inside):
            continue
        walk = _walking(fields, positions[inside]) / speeds[inside - members[0], None]
        own = np.array([taken[int(a)] for a in inside])
        best = np.argmin(walk, axis=1)
        rows = np.arange(len(inside))
        switch = walk[rows, best] < walk[rows, own] - margin
        for a, k in zip(inside[switch].tolist(), best[switch].tolist()):
            sim.switch_agent_journey(ids[a], *options[k])
            taken[a] = k


def run_jupedsim(model_name: str, scene: Scene, groups, seed: int, max_time_s: float) -> Trajectories:
    """One run of JuPedSim's ``model_name`` ("csm", "avm" or "sfm") on a crowdmotion scene
    and its groups, recorded every 0.25 s as crowdmotion Trajectories (agents that left
    through their goal: active False, held at their last position). The run ends when
    everyone has left, at ``max_time_s``, when nobody still inside has moved FREEZE_M in
    FREEZE_S seconds (``frozen``), or when JuPedSim raises (``error``, its message; the
    frames up to the last good one are kept). ``metadata`` also holds ``all_left``,
    ``agents_left``, ``end_time`` (s), ``max_speed`` (m/s, between recorded frames) and
    ``wall_s``."""
    wall0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    sim = jps.Simulation(model=_model(model_name, seed), geometry=walkable_area(scene), dt=DT)
    ids, names, start = [], [], []
    choosers = []  # (agent indices, the options' (journey, exit) ids, their fields, speeds, rechoose s, margin s)
    taken = {}  # agent index -> the option it is bound for (choosers' agents)
    for g in groups:
        placed = np.array(start, dtype=float).reshape(-1, 2)  # groups may share a spawn region
        pos = spawn_positions(scene, g, placed, np.full(len(placed), RADIUS), SPAWN_GAP, rng)
        rng_speed = g.attributes.get("pref_speed_range") if g.attributes else None
        speeds = rng.uniform(*rng_speed, size=len(pos)) if rng_speed else np.full(len(pos), g.pref_speed)
        exits, choice = _exits(g)
        options = []
        for area in exits:
            exit_id = sim.add_exit_stage(_rect_polygon(area))
            options.append((sim.add_journey(jps.JourneyDescription([exit_id])), exit_id))
        first = np.zeros(len(pos), dtype=np.int64)
        if choice is not None:  # the nearest exit, as crowdmotion's walkers choose it
            fields = distance_fields(scene, exits, RADIUS)
            first = np.argmin(_walking(fields, pos), axis=1)
            members = np.arange(len(ids), len(ids) + len(pos))
            choosers.append((members, options, fields, speeds, *choice))
            taken.update(zip(members.tolist(), first.tolist()))
        for p, v, k in zip(pos, speeds, first):
            ids.append(sim.add_agent(_agent_parameters(model_name, p, v, *options[k])))
            names.append(g.name)
            start.append(p)

    index = {aid: k for k, aid in enumerate(ids)}
    last = np.array(start, dtype=float).reshape(-1, 2)
    frames, active = [], []

    def record():
        act = np.zeros(len(ids), dtype=bool)
        for a in sim.agents():
            k = index[a.id]
            last[k] = a.position
            act[k] = True
        frames.append(last.copy())
        active.append(act)

    record()
    max_iter = int(round(max_time_s / DT))
    window = int(round(FREEZE_S / (RECORD_EVERY * DT)))
    error, frozen = None, False
    while sim.agent_count() > 0 and sim.iteration_count() < max_iter:
        try:
            sim.iterate(RECORD_EVERY)
        except RuntimeError as exc:  # e.g. the SFM pushing an agent out of the walkable area
            error = f"{exc} (at t = {sim.elapsed_time():.2f} s)"
            break
        record()
        _rechoose(sim, choosers, taken, ids, active[-1], last, len(frames) * RECORD_EVERY * DT)
        if len(frames) > window:  # frozen: nobody still in has moved FREEZE_M in FREEZE_S
            still = active[-1] & active[-1 - window]
            if still.any() and np.linalg.norm(frames[-1][still] - frames[-1 - window][still], axis=1).max() < FREEZE_M:
                frozen = True
                break
    remaining = int(active[-1].sum())
    pos, act = np.stack(frames), np.stack(active)
    both = act[1:] & act[:-1]
    step = np.linalg.norm(np.diff(pos, axis=0), axis=2) / (RECORD_EVERY * DT)
    meta = {"method": f"jupedsim.{MODEL_NAMES[model_name]}", "jupedsim_version": jps.__version__, "seed": seed,
            "dt_sim": DT, "end_time": (len(frames) - 1) * RECORD_EVERY * DT, "all_left": remaining == 0,
            "agents_left": len(ids) - remaining, "frozen": frozen, "error": error,
            "max_speed": float(step[both].max()) if both.any() else 0.0,
            "wall_s": time.perf_counter() - wall0}
    return Trajectories(pos, RECORD_EVERY * DT, ids=np.arange(len(ids)), group=np.array(names, object),
                        radius=np.full(len(ids), RADIUS), active=act, metadata=meta)


# ---- the suite's cases ---------------------------------------------------------------------------
def _bottleneck_setups():
    return {float(name.split()[1]): st for name, st in empirical._bottleneck("rvo").items()}


def _uo_setups():
    return empirical._uo("rvo")


def counterflow_points(model: str, seeds, max_time_s: float = MAX_TIME_S["counterflow"], runs: list | None = None):
    """(run, density, speed, lane order, shuffled lane order) of each BOT-360 run, the
    means over ``seeds``, measured as :func:`crowdmotion.empirical.bot_measures`; runs
    JuPedSim stopped with an error left out."""
    out = []
    for name, st in empirical._bot("rvo").items():
        pts = []
        for s in seeds:
            tr = run_jupedsim(model, st.scene, st.groups, s, max_time_s)
            pts.append((np.nan,) * 4 if tr.metadata["error"] else empirical.bot_measures(tr, np.random.default_rng(0)))
            if runs is not None:
                runs.append((name, s, tr))
        out.append((name, *map(float, _mean(pts, axis=0))))
    return out


def _mean(values, axis=None):
    """Mean over the runs that gave a number (NaN if none did)."""
    v = np.asarray(values, dtype=float)
    ok = np.isfinite(v).all(axis=-1) if v.ndim > 1 else np.isfinite(v)
    return np.mean(v[ok], axis=axis) if ok.any() else np.full(v.shape[1:], np.nan)


def bottleneck_flows(model: str, seeds, max_time_s: float = MAX_TIME_S["bottleneck"], runs: list | None = None):
    """Width -> mean stationary flow (persons/s) over ``seeds``: the crossings of x = 12
    going +x, as :func:`crowdmotion.empirical.bottleneck_flows`. ``runs`` (a list) gets
    (width, seed, Trajectories) of each run. A run JuPedSim stopped with an error counts
    as NaN (left out of the mean)."""
    out = {}
    for width, st in _bottleneck_setups().items():
        flows = []
        for s in seeds:
            tr = run_jupedsim(model, st.scene, st.groups, s, max_time_s)
            flows.append(float("nan") if tr.metadata["error"] else stationary(crossing_times(tr, 0, 12.0))[2])
            if runs is not None:
                runs.append((width, s, tr))
        out[width] = float(_mean(flows))
    return out


def open_corridor_points(model: str, seeds, max_time_s: float = MAX_TIME_S["corridor"], runs: list | None = None):
    """(run, density, speed) of each UO run: classical density and mean speed in UO_AREA
    over the stationary part of the crossings of x = 18.2, the means over ``seeds`` (as
    :func:`crowdmotion.empirical.uo_points`); runs JuPedSim stopped with an error left out."""
    out = []
    for name, st in _uo_setups().items():
        pts = []
        for s in seeds:
            tr = run_jupedsim(model, st.scene, st.groups, s, max_time_s)
            start, end, _ = stationary(crossing_times(tr, 0, 18.2))
            pts.append((np.nan, np.nan) if tr.metadata["error"] else area_density_speed(tr, *UO_AREA, start, end))
            if runs is not None:
                runs.append((name, s, tr))
        out.append((name, *map(float, _mean(pts, axis=0))))
    return out


def _left(runs) -> str:
    """' (n/N left, why)' summed over the runs: '' if every agent of every run left."""
    n = sum(int(tr.metadata["agents_left"]) for *_, tr in runs)
    total = sum(tr.n_agents for *_, tr in runs)
    why = [f"frozen by {tr.metadata['end_time']:.0f} s" for *_, tr in runs if tr.metadata["frozen"]]
    why += [f"crashed at {tr.metadata['end_time']:.0f} s" for *_, tr in runs if tr.metadata["error"]]
    why += [f"cut at {tr.metadata['end_time']:.0f} s" for *_, tr in runs
            if not (tr.metadata["all_left"] or tr.metadata["frozen"] or tr.metadata["error"])]
    vmax = max(tr.metadata["max_speed"] for *_, tr in runs)
    notes = ([f"{n}/{total} left"] if n < total else []) + why + ([f"max v {vmax:.0f} m/s"] if vmax > 3.0 else [])
    return f" ({', '.join(notes)})" if notes else ""


def _num(x: float, fmt: str = ".2f") -> str:
    return format(x, fmt) if np.isfinite(x) else "—"


def _mae(errors) -> str:
    """'mean (k/n)' over the finite errors."""
    e = np.asarray(errors, dtype=float)
    ok = np.isfinite(e)
    return f"{e[ok].mean():.3f}" + ("" if ok.all() else f" ({ok.sum()}/{len(e)})") if ok.any() else "—"


ERRORS: list[str] = []  # JuPedSim errors that ended runs, printed under the tables


def _note_errors(model: str, runs) -> None:
    ERRORS.extend(f"{model} {case} seed {s}: {tr.metadata['error']}" for case, s, tr in runs if tr.metadata["error"])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=1, help="seeds 0..N-1 per set-up (default 1)")
    ap.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    ap.add_argument("--cases", nargs="+", choices=("bottleneck", "corridor", "counterflow"),
                    default=["bottleneck", "corridor", "counterflow"])
    ap.add_argument("--max-time", type=float, default=None, help="cap on simulated seconds per run (default 400)")
    args = ap.parse_args(argv)
    if args.seeds < 1:
        ap.error("--seeds must be at least 1")
    seeds = list(range(args.seeds))
    wall = {m: {} for m in args.models}
    summary = {m: {} for m in args.models}

    if "bottleneck" in args.cases:
        flows, left = {}, {}
        for m in args.models:
            t0, runs = time.perf_counter(), []
            flows[m] = bottleneck_flows(m, seeds, args.max_time or MAX_TIME_S["bottleneck"], runs)
            wall[m]["bottleneck"] = time.perf_counter() - t0
            _note_errors(m, runs)
            left[m] = {w: _left([r for r in runs if r[0] == w]) for w in flows[m]}
        print(f"\n### Bottleneck flow (persons/s), JuPedSim {jps.__version__} defaults, seeds {args.seeds}\n")
        print("| width (m) | data mean | " + " | ".join(f"{m} J | {m} err" for m in args.models) + " |")
        print("|---|---|" + "---|---|" * len(args.models))
        for w in BOTTLENECK_WIDTHS:
            ref = float(np.mean(BOTTLENECK_FLOWS[w]))
            cells = [f"{_num(flows[m][w])}{left[m][w]} | {_num((flows[m][w] - ref) / ref, '+.0%')}" for m in args.models]
            print(f"| {w:g} | {ref:.2f} | " + " | ".join(cells) + " |")
        for m in args.models:
            summary[m]["bottleneck"] = _mae([abs(flows[m][w] - np.mean(BOTTLENECK_FLOWS[w])) for w in BOTTLENECK_WIDTHS])

    if "corridor" in args.cases:
        print(f"\n### Open corridor UO-180: density (/m²) and speed (m/s) in {UO_AREA}, seeds {args.seeds}\n")
        print("| run | model | ρ | v | Weidmann v(ρ) | nearest FZJ UG (ρ, v) |")
        print("|---|---|---|---|---|---|")
        rows = []
        for m in args.models:
            t0, runs = time.perf_counter(), []
            pts = open_corridor_points(m, seeds, args.max_time or MAX_TIME_S["corridor"], runs)
            wall[m]["corridor"] = time.perf_counter() - t0
            _note_errors(m, runs)
            errs_w, errs_ug = [], []
            for name, rho, v in pts:
                w = float(weidmann_speed(rho)) if np.isfinite(rho) else float("nan")
                ug = min(UG_RUNS, key=lambda r: abs(r[0] - rho)) if np.isfinite(rho) else (np.nan, np.nan)
                errs_w.append(abs(v - w))
                errs_ug.append(abs(v - ug[1]))
                rows.append((name, m, rho, v, w, ug, _left([r for r in runs if r[0] == name])))
            summary[m]["corridor_w"], summary[m]["corridor_ug"] = _mae(errs_w), _mae(errs_ug)
        order = {name: k for k, name in enumerate(_uo_setups())}
        for name, m, rho, v, w, ug, lf in sorted(rows, key=lambda r: (order[r[0]], args.models.index(r[1]))):
            print(f"| {name} | {m}{lf} | {_num(rho)} | {_num(v)} | {_num(w)} | "
                  + (f"({ug[0]:.2f}, {ug[1]:.2f}) |" if np.isfinite(ug[0]) else "— |"))

    if "counterflow" in args.cases:
        print(f"\n### Counterflow BOT-360: density (/m²), speed (m/s) and lane order in {empirical.BOT_AREA}, "
              f"seeds {args.seeds}\n")
        print("| run | model | ρ | v | nearest FZJ BOT (ρ, v) | lane order (shuffled) |")
        print("|---|---|---|---|---|---|")
        for m in args.models:
            t0, runs = time.perf_counter(), []
            pts = counterflow_points(m, seeds, args.max_time or MAX_TIME_S["counterflow"], runs)
            wall[m]["counterflow"] = time.perf_counter() - t0
            _note_errors(m, runs)
            errs = []
            for name, rho, v, order, base in pts:
                ref = min(empirical.BOT_360_RUNS, key=lambda r: abs(r[0] - rho)) if np.isfinite(rho) else (np.nan,) * 2
                errs.append(abs(v - ref[1]))
                print(f"| {name} | {m}{_left([r for r in runs if r[0] == name])} | {_num(rho)} | {_num(v)} | "
                      + (f"({ref[0]:.2f}, {ref[1]:.2f})" if np.isfinite(ref[0]) else "—")
                      + f" | {_num(order)} ({_num(base)}) |")
            summary[m]["counterflow"] = _mae(errs)

    if ERRORS:
        print("\nRuns ended by a JuPedSim error (left out of the measures):\n")
        print("\n".join(f"- {e}" for e in ERRORS))

    print("\n### Mean absolute error against the data (over the runs with a value: (k/n)), and wall time\n")
    print("| model | bottleneck mean abs(J - data) (/s) | corridor mean abs(v - Weidmann) (m/s) "
          "| corridor mean abs(v - FZJ UG) (m/s) | counterflow mean abs(v - FZJ BOT) (m/s) | wall time (s) |")
    print("|---|---|---|---|---|---|")
    for m in args.models:
        s = summary[m]
        f = lambda k: s.get(k, "—")  # noqa: E731
        wt = ", ".join(f"{c} {t:.1f}" for c, t in wall[m].items())
        print(f"| {m} ({MODEL_NAMES[m]}) | {f('bottleneck')} | {f('corridor_w')} | {f('corridor_ug')} "
              f"| {f('counterflow')} | {wt} |")


if __name__ == "__main__":
    main()
