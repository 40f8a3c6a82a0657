"""How the MDP method scales with threads: the bucket solver's large-grid timings
(1000x1000 and 200x200x200, corner cutting on and off; mean and best of 5) and Algorithm
3's throughput (bench_mdp.py's 10,000 agents x 200 steps on 1000x1000, and 40,000 agents
on the same grid; M agent-steps/s, mean and best of 5, with a digest of the paths, which
must not change with the thread count) at NUMBA_NUM_THREADS = 1, 2, 4, 8, 16, each in a
fresh process.

    python benchmarks/bench_mdp_threads.py [--threads 1 2 4 8 16] [--src src]

It loads ``crowdmotion.mdp.solvers`` from ``--src`` without the rest of the package, so
it runs on a bare many-core machine that has only numpy, scipy and numba.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

CHILD = r"""
import sys, time, types
src = sys.argv[1]
for name, path in (("crowdmotion", "crowdmotion"), ("crowdmotion.mdp", "crowdmotion/mdp")):
    m = types.ModuleType(name); m.__path__ = [f"{src}/{path}"]; sys.modules[name] = m
scene = types.ModuleType("crowdmotion.scene"); scene.Scene = object; sys.modules["crowdmotion.scene"] = scene
import hashlib
import numba
import numpy as np
from crowdmotion.mdp.solvers import fast_values
from crowdmotion.mdp.trajectory import generate_trajectories

def paper_grid(shape, lower, upper):
    g = np.zeros(shape, dtype=np.uint8)
    g[tuple(slice(lo, hi + 1) for lo, hi in zip(lower, upper))] = 1
    return g

def mean_best(fn, repeats=5):
    fn()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter(); fn(); ts.append(time.perf_counter() - t)
    return float(np.mean(ts)), min(ts)

g2 = paper_grid((1000, 1000), (500, 250), (500, 750))
g3 = paper_grid((200, 200, 200), (100, 50, 50), (100, 150, 150))
cells = [f"{numba.get_num_threads()}"]
for cc in (True, False):
    m, b = mean_best(lambda: fast_values(g2, [(999, 500)], cc))
    cells.append(f"{m * 1e3:.1f} ms ({b * 1e3:.1f})")
    m, b = mean_best(lambda: fast_values(g3, [(199, 100, 100)], cc))
    cells.append(f"{m:.3f} s ({b:.3f})")
grid = paper_grid((1000, 1000), (500, 300), (500, 699))  # bench_mdp.py's Algorithm 3 scene
v = fast_values(grid, [(999, 500)], True)
free = np.argwhere(grid[:400] == 0)
paths = hashlib.sha256()
for n in (10_000, 40_000):
    starts = free[np.random.default_rng(0).choice(len(free), n, replace=False)]
    run = lambda: generate_trajectories(grid, v, starts, 200, np.random.default_rng(1))
    m, b = mean_best(run)
    paths.update(np.ascontiguousarray(run()).tobytes())
    cells.append(f"{n * 200 / m / 1e6:.2f} M/s ({n * 200 / b / 1e6:.2f})")
cells.append(paths.hexdigest()[:12])
print("| " + " | ".join(cells) + " |")
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, nargs="*", default=[1, 2, 4, 8, 16])
    ap.add_argument("--src", default=os.path.join(os.path.dirname(__file__), "..", "src"))
    args = ap.parse_args()
    print("| threads | 1000² on, mean (best) | 200³ on | 1000² off | 200³ off | Algorithm 3, 10k agents | "
          "40k agents | paths digest |")
    print("|---|---|---|---|---|---|---|---|")
    for t in args.threads:
        env = dict(os.environ, NUMBA_NUM_THREADS=str(t))
        subprocess.run([sys.executable, "-c", CHILD, os.path.abspath(args.src)], env=env, check=True)


if __name__ == "__main__":
    main()
