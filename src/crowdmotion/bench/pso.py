"""PSO benchmark, side by side in one run.

A. Batched canonical PSO: 334 swarms × 30 particles × 100 iterations in 3D (the
   paper's defaults: c1 = c2 = 2, w = 1, v_max 0.5 per axis, start range ±20 round each
   swarm's own target), no avoidance, every particle kept moving (threshold 1e-9) so all
   three do the same work:
   - crowdmotion.pso.Swarm: all swarms in one numba call per iteration;
   - PySwarms 1.3 backend loop (create_swarm, compute_pbest, Star topology
     compute_gbest / compute_velocity with clamp / compute_position), one optimiser per
     swarm, as its docs write a custom loop;
   - the paper's algorithm in plain Python (lists and loops, one particle and axis at a time).
B. 10,000 particles (334 × 30) × 100 iterations with both avoidances on (redirect rule
   against obstacles and other particles, separation step), 3D, 1000 spherical obstacles:
   - "gathering": the paper's behaviour, particles stop when they arrive;
   - "never arriving": threshold 1e-9 and no gathering radius, so every particle moves
     and pushes against the others all 100 iterations (the worst case).

    pip install ".[bench]"
    crowdmotion bench pso [--repeats 3] [--skip-python]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from crowdmotion import Scene, Sphere
from crowdmotion.pso import PSOParams, Swarm

G, P, ITERS = 334, 30, 100
VMAX, C1, C2, W = 0.5, 2.0, 2.0, 1.0


def layout(rng):
    """Targets on a 60 m lattice, starts within ±20 m of their own target."""
    lat = np.stack(np.meshgrid(*[np.arange(7)] * 3, indexing="ij"), -1).reshape(-1, 3)[:G] * 60.0
    starts = lat[:, None, :] + rng.uniform(-20, 20, (G, P, 3))
    return lat, starts


def best_of(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def ours_batched(targets, starts, params, scene=None):
    sw = Swarm(starts.reshape(-1, 3), np.repeat(np.arange(G), P), targets, 0.25, params, scene,
               np.random.default_rng(1))

    def go():
        for _ in range(ITERS):
            sw.iterate()
    return sw, go


def pyswarms_loop(targets, starts):
    import pyswarms.backend as PB
    from pyswarms.backend.topology import Star

    topo = Star()
    for g in range(G):
        t = targets[g]
        swarm = PB.create_swarm(n_particles=P, dimensions=3, options={"c1": C1, "c2": C2, "w": W},
                                init_pos=starts[g].copy(), clamp=(-VMAX, VMAX))
        swarm.pbest_cost = np.full(P, np.inf)
        for _ in range(ITERS):
            swarm.current_cost = np.linalg.norm(swarm.position - t, axis=1)
            swarm.pbest_pos, swarm.pbest_cost = PB.compute_pbest(swarm)
            swarm.best_pos, swarm.best_cost = topo.compute_gbest(swarm)
            swarm.velocity = topo.compute_velocity(swarm, clamp=(-VMAX, VMAX))
            swarm.position = topo.compute_position(swarm)


def plain_python(targets, starts):
    import math
    import random

    rnd = random.Random(0)
    for g in range(G):
        t = targets[g].tolist()
        x = starts[g].tolist()
        v = [[rnd.uniform(-VMAX, VMAX) for _ in range(3)] for _ in range(P)]
        pb = [list(p) for p in x]
        pbd = [math.dist(p, t) for p in x]
        best = min(range(P), key=lambda i: pbd[i])
        gb, gbd = list(pb[best]), pbd[best]
        for _ in range(ITERS):
            for i in range(P):
                xi, vi, pi = x[i], v[i], pb[i]
                for a in range(3):
                    va = W * vi[a] + C1 * rnd.random() * (pi[a] - xi[a]) + C2 * rnd.random() * (gb[a] - xi[a])
                    vi[a] = max(-VMAX, min(VMAX, va))
                    xi[a] += vi[a]
                d = math.dist(xi, t)
                if d < pbd[i]:
                    pbd[i], pb[i] = d, list(xi)
            for i in range(P):
                if pbd[i] < gbd:
                    gbd, gb = pbd[i], list(pb[i])


def obstacles(targets, starts, rng, m=1000):
    flat = starts.reshape(-1, 3)
    out = []
    while len(out) < m:
        c = rng.uniform(-20, 380, 3)
        if np.min(np.linalg.norm(targets - c, axis=1)) > 6 and np.min(np.linalg.norm(flat - c, axis=1)) > 2.5:
            out.append(Sphere(c, 2.0))
    return Scene(bounds=([-40.0] * 3, [400.0] * 3), obstacles=out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="crowdmotion bench pso")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-python", action="store_true", help="leave out the slow plain-Python baseline")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    targets, starts = layout(rng)

    print(f"A. {G} swarms x {P} particles x {ITERS} iterations, 3D, no avoidance (best of {args.repeats})")
    keep_moving = PSOParams(avoid_agents=False, threshold=1e-9, stop_when_done=False)
    ours_batched(targets, starts, keep_moving)[0].iterate()  # compile
    t_ours = best_of(lambda: ours_batched(targets, starts, keep_moving)[1](), args.repeats)
    rows = [("crowdmotion.pso (numba, all swarms at once)", t_ours)]
    try:
        rows.append(("PySwarms 1.3 backend loop", best_of(lambda: pyswarms_loop(targets, starts), args.repeats)))
    except ImportError:
        print("(PySwarms is not installed: pip install \"crowdmotion[bench]\" to compare with it)")
    if not args.skip_python:
        rows.append(("paper's algorithm, plain Python", best_of(lambda: plain_python(targets, starts), 1)))
    print("| implementation | time | ours faster by |\n|---|---|---|")
    for name, t in rows:
        print(f"| {name} | {t * 1e3:.1f} ms | {t / t_ours:.1f}x |")

    print(f"\nB. {G * P} particles x {ITERS} iterations, both avoidances on, 1000 spheres (best of {args.repeats})")
    scene = obstacles(targets, starts, np.random.default_rng(5))
    print("| workload | time | moving particle-iterations | rule redirects | separation cuts |\n|---|---|---|---|---|")
    for name, params in (("gathering", PSOParams(stop_when_done=False)),
                         ("never arriving", PSOParams(threshold=1e-9, gather_slack=1.0, join_gap=0.0,
                                                      stop_when_done=False))):
        sw, go = ours_batched(targets, starts, params, scene)
        sw.iterate()
        best = np.inf
        for _ in range(args.repeats):
            sw, go = ours_batched(targets, starts, params, scene)
            t = time.perf_counter()
            go()
            best = min(best, time.perf_counter() - t)
        s = sw.stats
        redirects = s["obstacle_redirects"] + s["agent_redirects"]
        cuts = s["separation_truncations"] + s["separation_stops"]
        print(f"| {name} | {best * 1e3:.0f} ms | {s['moving_particle_iterations']:,} | {redirects:,} | {cuts:,} |")


if __name__ == "__main__":
    main()
