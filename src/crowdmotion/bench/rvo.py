"""RVO benchmark, side by side in one run: crowdmotion.rvo against pyrvo (RVO2/ORCA, C++)
and JuPedSim (collision-free speed model, C++) on the same scenes.

Open scenes, ms per step (agents of radius 0.25 m on a jittered 1 m lattice, 1 agent/m²):
- circle:   a filled disc, everyone heads for the mirror point through the centre;
- crossing: two blocks face each other and walk through each other.

The stand evacuation (the built-in ``rvo_stand_evacuation``: people leave a 60 x 25 m
stand by three 2 m exits), whole runs until everyone is out, wall time: see
:func:`stand_table`. Threads on a busy machine: see :func:`threads_table`.

    pip install ".[bench]"
    crowdmotion bench rvo [--sizes 1000 5000 10000] [--steps 20] [--stand 2000 500]
                          [--jupedsim-max 500] [--threads-check]

Our step is the whole step (guidance, neighbours, N_sample = 50 candidates against
M = 10 neighbours, the safety pass, the move). pyrvo is timed twice: ``do_step`` alone
(its C++ core) and with the Python loop that sets preferred velocities and reads the
positions back, which any pyrvo user has to run. The two step in turn, ours then
pyrvo's, so a machine whose speed drifts mid-run (a shared one does, by a third and more)
weighs on both alike. JuPedSim runs at its own dt = 0.01 s
(our dt is 0.25 s), so its column is per iteration and the last column per simulated second.
"""

from __future__ import annotations

import argparse
import multiprocessing
import time

import numba
import numpy as np
from scipy.spatial import cKDTree

import crowdmotion as cm
from crowdmotion import _threads, rvo

RADIUS = 0.25
SPEED = 1.3
DT = 0.25


def lattice(n: int, rng: np.random.Generator, shape: str) -> tuple[np.ndarray, np.ndarray]:
    """(positions, goals) for ``n`` agents: jittered 1 m lattice, no two closer than 0.6 m."""
    if shape == "circle":
        r = np.sqrt(n / np.pi) + 2
        g = np.arange(-np.ceil(r), np.ceil(r) + 1)
        pts = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
        pts = pts[np.argsort(np.linalg.norm(pts, axis=1), kind="stable")][:n]
        pos = pts + rng.uniform(-0.2, 0.2, pts.shape)
        return pos, -pos
    half = n // 2
    side = int(np.ceil(np.sqrt(half)))
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:half].astype(float)
    a = g + rng.uniform(-0.2, 0.2, g.shape)
    b = g + [side + 4.0, 0.0] + rng.uniform(-0.2, 0.2, g.shape)
    shift = np.array([side + 4.0, 0.0])
    pos = np.concatenate([a, b])[:n]
    goal = np.concatenate([a + 2 * shift, b - 2 * shift])[:n]
    return pos, goal


def bounds(pos, goal):
    allp = np.concatenate([pos, goal])
    return allp.min(axis=0) - 5, allp.max(axis=0) + 5


def open_simulator(pos, goal) -> rvo.Simulator:
    """Our Simulator of an open scene, stepped twice (guidance, first compiles)."""
    lo, hi = bounds(pos, goal)
    sim = rvo.Simulator(cm.Scene(bounds=(lo, hi)), time_step=DT, guidance="direct", rng=np.random.default_rng(0))
    sim.add_agents(pos, goal, radius=RADIUS, max_speed=1.5, pref_speed=SPEED, max_neighbors=10,
                   neighbor_dist=5.0, samples=50, safety=5.0)
    sim.step()
    sim.step()
    return sim


def ours(pos, goal, steps: int) -> float:
    """Seconds per step of our whole step in an open scene (mean of ``steps``)."""
    sim = open_simulator(pos, goal)
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps


def pyrvo_stepper(pos, goal):
    """pyrvo's ORCA on an open scene (our defaults' radius, speeds, neighbours), stepped
    once; returns a function doing one more step that gives (seconds of ``do_step``,
    seconds with the Python loop that sets preferred velocities and reads positions back)."""
    import pyrvo

    sim = pyrvo.RVOSimulator()
    sim.set_time_step(DT)
    sim.set_agent_defaults(5.0, 10, 2.0, 2.0, RADIUS, 1.5)
    for p in pos:
        sim.add_agent((float(p[0]), float(p[1])))
    n = len(pos)

    def set_pref():
        cur = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
        d = goal - cur
        dist = np.linalg.norm(d, axis=1, keepdims=True)
        v = np.where(dist > 0, d / np.maximum(dist, 1e-9) * np.minimum(SPEED, dist / DT), 0.0)
        for i in range(n):
            sim.set_agent_pref_velocity(i, (float(v[i, 0]), float(v[i, 1])))

    def step() -> tuple[float, float]:
        t0 = time.perf_counter()
        set_pref()
        t1 = time.perf_counter()
        sim.do_step()
        t2 = time.perf_counter()
        return t2 - t1, t2 - t0

    set_pref()
    sim.do_step()
    return step


def pyrvo_times(pos, goal, steps: int) -> tuple[float, float]:
    """Seconds per step of pyrvo's ``do_step`` and of its step with the Python loop
    round it (means of ``steps``)."""
    step = pyrvo_stepper(pos, goal)
    core, full = np.mean([step() for _ in range(steps)], axis=0)
    return float(core), float(full)


def side_by_side(pos, goal, steps: int) -> tuple[float, float, float]:
    """Seconds per step (means of ``steps``) of our whole step, pyrvo's ``do_step`` and
    pyrvo's step with its Python loop, the two simulators stepping in turn (ours, then
    pyrvo, each step): a machine that slows down or speeds up mid-run weighs on both alike.
    pyrvo's figures are NaN where it is not installed."""
    sim = open_simulator(pos, goal)
    try:
        peer = pyrvo_stepper(pos, goal)
    except ImportError:
        peer = None
    mine, core, full = [], [], []
    for _ in range(steps):
        t0 = time.perf_counter()
        sim.step()
        mine.append(time.perf_counter() - t0)
        if peer is not None:
            c, f = peer()
            core.append(c)
            full.append(f)
    nan = float("nan")
    return float(np.mean(mine)), float(np.mean(core)) if core else nan, float(np.mean(full)) if full else nan


def jupedsim_time(pos, goal, steps: int) -> float:
    import jupedsim as jps
    import shapely

    lo, hi = bounds(pos, goal)
    sim = jps.Simulation(model=jps.CollisionFreeSpeedModel(), geometry=shapely.box(lo[0], lo[1], hi[0], hi[1]),
                         dt=0.01)
    # one exit per 1/16 of the goals' directions (JuPedSim routes to shared stages)
    ang = np.arctan2(goal[:, 1] - pos[:, 1], goal[:, 0] - pos[:, 0])
    sector = ((ang + np.pi) / (2 * np.pi) * 16).astype(int) % 16
    journeys = {}
    for s in np.unique(sector):
        c = goal[sector == s].mean(axis=0)
        exit_id = sim.add_exit_stage(shapely.box(c[0] - 1, c[1] - 1, c[0] + 1, c[1] + 1))
        journeys[s] = (sim.add_journey(jps.JourneyDescription([exit_id])), exit_id)
    for p, s in zip(pos, sector):
        j, e = journeys[s]
        sim.add_agent(jps.CollisionFreeSpeedModelAgentParameters(position=(float(p[0]), float(p[1])), radius=RADIUS,
                                                                 desired_speed=SPEED, journey_id=j, stage_id=e))
    for _ in range(5):
        sim.iterate()
    t0 = time.perf_counter()
    sim.iterate(steps)
    return (time.perf_counter() - t0) / steps


# ---- the stand evacuation: whole runs ----------------------------------------------------------
STAND = "rvo_stand_evacuation"
JUPEDSIM_DT = 0.01


def stand_setup(count: int):
    """(scene, groups, params, seed) of the built-in stand evacuation with ``count`` people
    (its own 2000, or fewer on the same stand)."""
    import dataclasses

    from crowdmotion.builtin import builtin_scenarios
    from crowdmotion.scenario import load_scenario

    sc = load_scenario({p.stem: p for p in builtin_scenarios()}[STAND])
    groups = [dataclasses.replace(g, count=count) for g in sc.groups]
    return sc.scene, groups, sc.params, sc.spec.seed


def stand_simulator(count: int):
    """Our Simulator of the stand evacuation with ``count`` people, placed, not yet stepped."""
    from crowdmotion.rvo.simulation import build_simulator

    scene, groups, params, seed = stand_setup(count)
    return build_simulator(scene, groups, params, np.random.default_rng(seed)), params


def overlap_frames(frames, present, radius: float) -> tuple[int, float]:
    """(frames in which two bodies present overlap, the deepest overlap in metres)."""
    hit, deepest = 0, 0.0
    for pos, act in zip(frames, present):
        p = pos[act]
        if len(p) < 2:
            continue
        pairs = cKDTree(p).query_pairs(2 * radius, output_type="ndarray")
        if len(pairs):
            depth = 2 * radius - np.linalg.norm(p[pairs[:, 0]] - p[pairs[:, 1]], axis=1)
            if (depth > 1e-9).any():
                hit += 1
                deepest = max(deepest, float(depth.max()))
    return hit, deepest


# a first run on a fresh install compiles the kernels (numba caches them on disk), each
# kernel once for one thread and once for several (chosen by the crowd's size): the first
# steps of the same stand, beforehand, keep that out of the timed runs
WARM_UP_STEPS = 40


def warm_up(count: int) -> None:
    """Step the stand evacuation with ``count`` people ``WARM_UP_STEPS`` times, untimed."""
    sim, _ = stand_simulator(count)
    for _ in range(WARM_UP_STEPS):
        sim.step()


def ours_stand(count: int) -> dict:
    """Our run of the stand evacuation to the end (the built-in's settings: density-aware
    speeds, following, lanes, stand-off rules all on); wall time of the stepping."""
    sim, params = stand_simulator(count)
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    t0 = time.perf_counter()
    while sim.steps < params.max_steps and (sim.active & ~sim.arrived).any():
        sim.step()
        frames.append(sim.positions)
        present.append(sim.present)
    wall = time.perf_counter() - t0
    hit, deepest = overlap_frames(frames, present, float(sim.params["radius"].max()))
    return {"wall": wall, "core": float("nan"), "steps": sim.steps, "sim_s": sim.time,
            "out": int(sim.arrived.sum()), "overlap_frames": hit, "frames": len(frames), "deepest": deepest}


def _stand_walls(scene):
    """(the wall boxes across the stand, the exits' x, a way-point y just below the wall)."""
    boxes = sorted(scene.obstacles, key=lambda b: b.lower[0])
    doors = [0.5 * (a.upper[0] + b.lower[0]) for a, b in zip(boxes[:-1], boxes[1:]) if a.upper[0] < b.lower[0]]
    return boxes, np.array(doors), float(min(b.lower[1] for b in boxes))


def pyrvo_stand(count: int) -> dict:
    """pyrvo (RVO2's ORCA) on the same stand, starts, speeds and goals, at our time step:
    the wall boxes as RVO2 obstacles; each person walks to the exit nearest it until
    below the wall (a way-point 1 m below the exit), then to its goal; arrived (within
    0.5 m of the goal, as ours) it leaves, moved far away and blind (RVO2 cannot remove an
    agent). Neighbour distance and count as ours (10 m, 10), time horizons 2 s. Wall time
    of the whole loop (the Python loop setting preferred velocities included) and of
    ``do_step`` alone."""
    import pyrvo

    sim0, params = stand_simulator(count)
    pos0, goals, vpref = sim0.positions.copy(), sim0.goals.copy(), sim0.params["pref_speed"].copy()
    r, vmax, dt = float(sim0.params["radius"].max()), float(sim0.params["max_speed"].max()), params.time_step
    boxes, doors, wall_y = _stand_walls(sim0.scene)
    sim = pyrvo.RVOSimulator()
    sim.set_time_step(dt)
    sim.set_agent_defaults(float(sim0.params["neighbor_dist"].max()), int(sim0.params["max_neighbors"].max()),
                           2.0, 2.0, r, vmax)
    for p in pos0:
        sim.add_agent((float(p[0]), float(p[1])))
    for b in boxes:
        (x0, y0), (x1, y1) = b.lower, b.upper
        sim.add_obstacle([(float(x0), float(y0)), (float(x1), float(y0)), (float(x1), float(y1)),
                          (float(x0), float(y1))])
    sim.process_obstacles()
    n = len(pos0)
    out = np.zeros(n, dtype=bool)
    frames, present = [], []
    core, steps = 0.0, 0
    t0 = time.perf_counter()
    while steps < params.max_steps and not out.all():
        cur = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
        frames.append(cur)
        present.append(~out)
        now = ~out & (np.linalg.norm(goals - cur, axis=1) <= params.arrival_radius)
        for i in np.flatnonzero(now):
            sim.set_agent_position(int(i), (-1.0e4 - 50.0 * i, -1.0e4))
            sim.set_agent_velocity(int(i), (0.0, 0.0))
            sim.set_agent_max_neighbors(int(i), 0)
        out |= now
        door = doors[np.argmin(np.abs(cur[:, :1] - doors[None]), axis=1)]
        aim = np.where((cur[:, 1] > wall_y)[:, None], np.stack([door, np.full(n, wall_y - 1.0)], 1), goals)
        d = aim - cur
        dist = np.linalg.norm(d, axis=1, keepdims=True)
        v = d / np.maximum(dist, 1e-9) * np.minimum(vpref[:, None], dist / dt)
        v[out] = 0.0
        for i in range(n):
            sim.set_agent_pref_velocity(i, (float(v[i, 0]), float(v[i, 1])))
        t1 = time.perf_counter()
        sim.do_step()
        core += time.perf_counter() - t1
        steps += 1
    wall = time.perf_counter() - t0
    hit, deepest = overlap_frames(frames, present, r)
    return {"wall": wall, "core": core, "steps": steps, "sim_s": steps * dt, "out": int(out.sum()),
            "overlap_frames": hit, "frames": len(frames), "deepest": deepest}


def jupedsim_stand(count: int) -> dict:
    """JuPedSim's collision-free speed model on the same stand (walkable area: the bounds
    less the wall boxes), starts and desired speeds, at its own dt of 0.01 s; everyone
    leaves through one exit stage, the goal area, routed by JuPedSim. Wall time of the
    iterations; positions read every 0.25 s for the overlap count (not timed)."""
    import jupedsim as jps
    import shapely

    sim0, params = stand_simulator(count)
    (x0, y0), (x1, y1) = sim0.scene.bounds
    area = shapely.box(x0, y0, x1, y1).difference(
        shapely.union_all([shapely.box(*b.lower, *b.upper) for b in sim0.scene.obstacles]))
    r = float(sim0.params["radius"].max())
    sim = jps.Simulation(model=jps.CollisionFreeSpeedModel(), geometry=area, dt=JUPEDSIM_DT)
    goal = sim0._goal_regions[0]
    exit_id = sim.add_exit_stage(shapely.box(*goal.lower, *goal.upper))
    journey = sim.add_journey(jps.JourneyDescription([exit_id]))
    ids = [sim.add_agent(jps.CollisionFreeSpeedModelAgentParameters(
        position=(float(p[0]), float(p[1])), radius=r, desired_speed=float(v), journey_id=journey, stage_id=exit_id))
        for p, v in zip(sim0.positions, sim0.params["pref_speed"])]
    index = {a: k for k, a in enumerate(ids)}
    every = int(round(params.time_step / JUPEDSIM_DT))
    max_iter = int(round(params.max_steps * params.time_step / JUPEDSIM_DT))
    frames, present, wall = [], [], 0.0
    last = sim0.positions.copy()
    while sim.agent_count() > 0 and sim.iteration_count() < max_iter:
        act = np.zeros(len(ids), dtype=bool)
        for a in sim.agents():
            last[index[a.id]] = a.position
            act[index[a.id]] = True
        frames.append(last.copy())
        present.append(act)
        t0 = time.perf_counter()
        sim.iterate(every)
        wall += time.perf_counter() - t0
    hit, deepest = overlap_frames(frames, present, r)
    return {"wall": wall, "core": float("nan"), "steps": sim.iteration_count(), "sim_s": sim.elapsed_time(),
            "out": len(ids) - sim.agent_count(), "overlap_frames": hit, "frames": len(frames), "deepest": deepest}


def _peer(fn, *args):
    try:
        return fn(*args)
    except ImportError:
        return None


def stand_table(counts, jupedsim_max: int) -> list[str]:
    """Rows: for each number of people, our run, pyrvo's and (up to ``jupedsim_max``
    people) JuPedSim's, with our wall time over each peer's."""
    rows = ["| people | simulator | time step | steps | evacuated in (simulated) | out | wall | do_step alone "
            "| ours / it (wall) | frames with bodies overlapping (deepest) |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for count in counts:
        warm_up(count)
        ours = ours_stand(count)
        runs = [("crowdmotion.rvo", "0.25 s", ours), ("pyrvo (ORCA)", "0.25 s", _peer(pyrvo_stand, count))]
        if count <= jupedsim_max:
            runs.append(("JuPedSim (CSM)", f"{JUPEDSIM_DT} s", _peer(jupedsim_stand, count)))
        for name, dt, r in runs:
            if r is None:
                rows.append(f"| {count:,} | {name} | {dt} | not installed | | | | | | |")
                continue
            core = "" if np.isnan(r["core"]) else f"{r['core']:.2f} s"
            ratio = "" if r is ours else f"{ours['wall'] / r['wall']:.2f}x"
            rows.append(f"| {count:,} | {name} | {dt} | {r['steps']:,} | {r['sim_s']:.0f} s | {r['out']:,} "
                        f"| {r['wall']:.2f} s | {core} | {ratio} | {r['overlap_frames']:,} of {r['frames']:,} "
                        f"({r['deepest'] * 100:.1f} cm) |")
            print(rows[-1], flush=True)
        if count > jupedsim_max:
            rows.append(f"| {count:,} | JuPedSim (CSM) | {JUPEDSIM_DT} s | not run (--jupedsim-max {jupedsim_max}: "
                        "at 2,000 people it takes many minutes) | | | | | | |")
    return rows


# ---- threads on a busy machine -------------------------------------------------------------------
def _busy_loop() -> None:
    while True:
        pass


def _step_times(make, steps: int, threads: int) -> np.ndarray:
    """Seconds of each of ``steps`` steps of a fresh simulator on ``threads`` numba threads."""
    cap = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        sim = make()
        sim.step()  # guidance fields, first compiles
        out = np.empty(steps)
        for k in range(steps):
            t0 = time.perf_counter()
            sim.step()
            out[k] = time.perf_counter() - t0
        return out
    finally:
        numba.set_num_threads(cap)


def threads_table(steps: int, stand_steps: int) -> list[str]:
    """The 1000-agent open circle and the first ``stand_steps`` steps of the stand
    evacuation on one thread and on all of numba's, alone and beside a process keeping
    one core busy (a Python busy loop). Other processes on the machine count as well:
    the table gives the free cores measured before each run (``_threads.FreeCores``)."""
    cap = numba.get_num_threads()
    p, g = lattice(1000, np.random.default_rng(1), "circle")

    def circle():
        return open_simulator(p, g)

    def stand():
        return stand_simulator(2000)[0]

    rows = ["| scene | our busy loop beside | cores free of others' work before | threads | median step | p99 step "
            "| p99 / median | longest step | wall |",
            "|---|---|---|---|---|---|---|---|---|"]
    for load in ("none", "one core"):
        busy = None
        if load != "none":
            busy = multiprocessing.get_context("spawn").Process(target=_busy_loop, daemon=True)
            busy.start()
            time.sleep(2 * _threads.SAMPLE_S)
        try:
            for name, make, n in (("circle, 1,000 agents", circle, steps), ("stand evacuation, 2,000", stand,
                                                                            stand_steps)):
                for threads in sorted({1, cap}):
                    free = _threads._free_cores.cores() if _threads._free_cores else float("nan")
                    t = _step_times(make, n, threads) * 1e3
                    med, p99 = np.median(t), np.percentile(t, 99)
                    rows.append(f"| {name} ({n} steps) | {load} | {free:.1f} | {threads} | {med:.2f} ms "
                                f"| {p99:.2f} ms | {p99 / med:.1f}x | {t.max():.1f} ms | {t.sum() / 1e3:.2f} s |")
                    print(rows[-1], flush=True)
        finally:
            if busy is not None:
                busy.terminate()
                busy.join()
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="crowdmotion bench rvo")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 5000, 10000],
                    help="agents in the open scenes (none: skip them)")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--stand", type=int, nargs="*", default=[2000, 500],
                    help="people in the stand evacuation, whole runs (none: skip it)")
    ap.add_argument("--jupedsim-max", type=int, default=500,
                    help="JuPedSim runs the stand evacuation up to this many people (2,000 take it over 10 minutes)")
    ap.add_argument("--threads-check", action="store_true",
                    help="also step on 1 thread and on all, idle and with one core kept busy")
    ap.add_argument("--threads-steps", type=int, nargs=2, default=[300, 300], metavar=("CIRCLE", "STAND"),
                    help="steps of the 1000-agent circle and of the stand evacuation in --threads-check")
    args = ap.parse_args(argv)
    # compile our kernels before timing
    p, g = lattice(50, np.random.default_rng(0), "circle")
    ours(p, g, 1)
    print(f"numba threads: {numba.get_num_threads()}; cores free of other work now: "
          f"{_threads._free_cores.cores() if _threads._free_cores else 'not measured'}", flush=True)
    tables = []
    if args.sizes:
        tables.append(open_table(args.sizes, args.steps))
    if args.stand:
        stand_simulator(100)[0].step()  # compile what the stand's scene adds (obstacles, fields)
        tables.append(stand_table(args.stand, args.jupedsim_max))
    if args.threads_check:
        tables.append(threads_table(*args.threads_steps))
    for rows in tables:
        print()
        print("\n".join(rows))


def open_table(sizes, steps: int) -> list[str]:
    """Rows: ms per step in the open scenes, ours against pyrvo and JuPedSim."""
    rows = ["| scene | agents | crowdmotion.rvo step | pyrvo do_step | pyrvo step + Python pref loop | ours / pyrvo core "
            "| JuPedSim iteration (dt 0.01 s) | ours / JuPedSim per step | ours / JuPedSim per simulated second |",
            "|---|---|---|---|---|---|---|---|---|"]
    for shape in ("circle", "crossing"):
        for n in sizes:
            pos, goal = lattice(n, np.random.default_rng(1), shape)
            t_ours, core, full = side_by_side(pos, goal, steps)
            try:
                t_j = jupedsim_time(pos, goal, 5 * steps)
            except ImportError:
                t_j = float("nan")
            per_sim_s = (t_ours / DT) / (t_j / 0.01)
            rows.append(f"| {shape} | {n:,} | {t_ours * 1e3:.1f} ms | {core * 1e3:.1f} ms | {full * 1e3:.1f} ms | "
                        f"{t_ours / core:.2f}x | {t_j * 1e3:.2f} ms | {t_ours / t_j:.2f}x | {per_sim_s:.3f}x |")
            print(rows[-1], flush=True)
    return rows


if __name__ == "__main__":
    main()
