"""MDP benchmarks, side by side in one run (see docs/performance.md for the command).

1. The paper's Tables 1-2: reference IVI / HVI / Dijkstra (plain Python), scipy csgraph
   (graph build + solve) and our exact "fast" solver on the paper's ten grids.
2. Large grids: fast vs scipy csgraph on 1000x1000; fast on 200x200x200.
3. Algorithm 3 throughput: 10,000 agents on a 1000x1000 grid, agent-steps per second.

    python benchmarks/bench_mdp.py [--quick]
"""

from __future__ import annotations

import argparse

import numpy as np

from crowdmotion import mdp
from crowdmotion.mdp.benchmark import csgraph_values, format_tables, paper_grid, run_paper_tables, timed, timed_runs
from crowdmotion.mdp.solvers import fast_values


def large_grids(repeats: int) -> list[str]:
    out = ["| grid | corner cutting | scipy csgraph (build + solve) | fast, mean (best) | speed-up of the mean |",
           "|---|---|---|---|---|"]
    g2 = paper_grid((1000, 1000), (500, 300), (500, 699))
    g3 = paper_grid((200, 200, 200), (100, 50, 50), (100, 149, 149))
    for cc in (True, False):
        fast_values(g2[:5, :5].copy(), [(0, 0)], cc)
        tf, v = timed_runs(lambda: fast_values(g2, [(999, 500)], cc), repeats)
        ts, ref = timed(lambda: csgraph_values(g2, [(999, 500)], cc), repeats)
        fin = np.isfinite(ref)
        assert np.max(np.abs(v[fin] - ref[fin])) < 1e-9
        mean = float(np.mean(tf))
        out.append(f"| 1000x1000 | {cc} | {ts:.3f} s | {mean * 1e3:.1f} ms ({min(tf) * 1e3:.1f} ms) | "
                   f"{ts / mean:.0f}x (target >= 20x) |")
    for cc in (True, False):
        fast_values(g3[:5, :5, :5].copy(), [(0, 0, 0)], cc)
        tf, _ = timed_runs(lambda: fast_values(g3, [(199, 100, 100)], cc), repeats)
        out.append(f"| 200x200x200 | {cc} | (not run: ~1.7 GB graph) | {np.mean(tf):.3f} s ({min(tf):.3f} s) | "
                   "target <= 0.3 s |")
    return out


def algorithm3(n_agents: int, steps: int, repeats: int) -> str:
    grid = paper_grid((1000, 1000), (500, 300), (500, 699))
    v = mdp.solve(grid, (999, 500))
    rng = np.random.default_rng(0)
    free = np.argwhere(grid[:400] == 0)
    starts = free[rng.choice(len(free), n_agents, replace=False)]
    mdp.generate_trajectories(grid, v, starts[:10], 2, rng)  # compile
    t, _ = timed_runs(lambda: mdp.generate_trajectories(grid, v, starts, steps, np.random.default_rng(1)), repeats)
    rate = [n_agents * steps / x / 1e6 for x in t]
    return (f"Algorithm 3, {n_agents:,} agents x {steps} steps on 1000x1000, forbid_crossing on: "
            f"{np.mean(t):.2f} s mean of {repeats} = {n_agents * steps / np.mean(t) / 1e6:.2f} M agent-steps/s "
            f"(best {max(rate):.2f}, worst {min(rate):.2f}; target >= 5)")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="skip the plain-Python reference solvers")
    ap.add_argument("--repeats", type=int, default=3, help="paper tables (the paper averaged 3); large grids run at least 5")
    args = ap.parse_args()
    print("## Paper Tables 1-2 (corner cutting on, as the paper)\n")
    print(format_tables(run_paper_tables(reference=not args.quick, repeats=args.repeats)))
    print("\n## Large grids\n")
    print("\n".join(large_grids(max(args.repeats, 5))))
    print("\n## Trajectory generation\n")
    print(algorithm3(10_000, 200, max(args.repeats, 5)))


if __name__ == "__main__":
    main()
