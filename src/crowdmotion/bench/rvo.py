"""RVO benchmark, side by side in one run: crowdmotion.rvo against pyrvo (RVO2/ORCA, C++)
and JuPedSim (collision-free speed model, C++), ms per step, on the same scenes.

Scenes (agents of radius 0.25 m on a jittered 1 m lattice, 1 agent/m²):
- circle:   a filled disc, everyone heads for the mirror point through the centre;
- crossing: two blocks face each other and walk through each other.

    pip install ".[bench]"
    crowdmotion bench rvo [--sizes 1000 5000 10000] [--steps 20]

Our step is the whole step (guidance, neighbours, N_sample = 50 candidates against
M = 10 neighbours, the safety pass, the move). pyrvo is timed twice: ``do_step`` alone
(its C++ core) and with the Python loop that sets preferred velocities and reads the
positions back, which any pyrvo user has to run. JuPedSim runs at its own dt = 0.01 s
(our dt is 0.25 s), so its column is per iteration and the last column per simulated second.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import crowdmotion as cm
from crowdmotion import rvo

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


def ours(pos, goal, steps: int) -> float:
    lo, hi = bounds(pos, goal)
    sim = rvo.Simulator(cm.Scene(bounds=(lo, hi)), time_step=DT, guidance="direct", rng=np.random.default_rng(0))
    sim.add_agents(pos, goal, radius=RADIUS, max_speed=1.5, pref_speed=SPEED, max_neighbors=10,
                   neighbor_dist=5.0, samples=50, safety=5.0)
    sim.step()
    sim.step()
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps


def pyrvo_times(pos, goal, steps: int) -> tuple[float, float]:
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

    set_pref()
    sim.do_step()
    core = full = 0.0
    for _ in range(steps):
        t0 = time.perf_counter()
        set_pref()
        t1 = time.perf_counter()
        sim.do_step()
        t2 = time.perf_counter()
        core += t2 - t1
        full += t2 - t0
    return core / steps, full / steps


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


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="crowdmotion bench rvo")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 5000, 10000])
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args(argv)
    # compile our kernels before timing
    p, g = lattice(50, np.random.default_rng(0), "circle")
    ours(p, g, 1)
    rows = ["| scene | agents | crowdmotion.rvo step | pyrvo do_step | pyrvo step + Python pref loop | ours / pyrvo core "
            "| JuPedSim iteration (dt 0.01 s) | ours / JuPedSim per step | ours / JuPedSim per simulated second |",
            "|---|---|---|---|---|---|---|---|---|"]
    for shape in ("circle", "crossing"):
        for n in args.sizes:
            pos, goal = lattice(n, np.random.default_rng(1), shape)
            t_ours = ours(pos, goal, args.steps)
            try:
                core, full = pyrvo_times(pos, goal, args.steps)
            except ImportError:
                core = full = float("nan")
            try:
                t_j = jupedsim_time(pos, goal, 5 * args.steps)
            except ImportError:
                t_j = float("nan")
            per_sim_s = (t_ours / DT) / (t_j / 0.01)
            rows.append(f"| {shape} | {n:,} | {t_ours * 1e3:.1f} ms | {core * 1e3:.1f} ms | {full * 1e3:.1f} ms | "
                        f"{t_ours / core:.2f}x | {t_j * 1e3:.2f} ms | {t_ours / t_j:.2f}x | {per_sim_s:.3f}x |")
            print(rows[-1], flush=True)
    print()
    print("\n".join(rows))


if __name__ == "__main__":
    main()
