"""Why Algorithm 3 gains little from many threads: the agent clusters of its threaded step.

Agents whose cells are within two of each other (Chebyshev) may affect each other's turn,
so ``mdp._kernels._clusters`` keeps each linked cluster on one thread, the thread whose
share of the step's priority order (largest value first) its lowest-id agent falls in.
This script runs bench_mdp.py's Algorithm 3 scene (1000x1000, a wall with a gap, the goal
beyond it; agents start in the first 400 rows), finds the clusters at a few steps with
``scipy.sparse.csgraph.connected_components`` and prints the largest cluster and how much
more than the mean share the busiest of ``parts`` threads carries; the step waits for it.

    python benchmarks/mdp_clusters.py [--agents 10000 40000] [--steps 200] [--parts 4 16]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from crowdmotion.mdp.solvers import fast_values
from crowdmotion.mdp.trajectory import generate_trajectories


def cluster_loads(cells: np.ndarray, values: np.ndarray, parts: int) -> tuple[int, float]:
    """(largest cluster, busiest part's load over the mean) of agents at ``cells`` ((N, D)
    grid cells) whose turns follow ``values`` at those cells (largest first, ties by id),
    shared between ``parts`` threads as ``_clusters`` shares them."""
    n = len(cells)
    pairs = cKDTree(cells).query_pairs(2.0, p=np.inf, output_type="ndarray")
    links = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(links, directed=False)
    lowest = np.full(label.max() + 1, n)
    np.minimum.at(lowest, label, np.arange(n))
    order = np.argsort(-values, kind="stable")
    place = np.empty(n, dtype=np.int64)
    place[order] = np.arange(n)
    load = np.bincount(place[lowest[label]] * parts // n, minlength=parts)
    return int(np.bincount(label).max()), float(load.max() / load.mean())


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--agents", type=int, nargs="+", default=[10_000, 40_000])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--parts", type=int, nargs="+", default=[4, 16])
    args = ap.parse_args(argv)
    grid = np.zeros((1000, 1000), dtype=np.uint8)
    grid[500, 300:700] = 1  # bench_mdp.py's wall, its gap at both ends
    values = fast_values(grid, [(999, 500)], True)
    free = np.argwhere(grid[:400] == 0)
    print("| agents | step | largest cluster | " + " | ".join(f"busiest of {p} parts / mean" for p in args.parts) + " |")
    print("|---|---|---|" + "---|" * len(args.parts))
    for n in args.agents:
        starts = free[np.random.default_rng(0).choice(len(free), n, replace=False)]
        paths = generate_trajectories(grid, values, starts, args.steps, np.random.default_rng(1))  # (steps + 1, N, 2)
        for step in sorted({0, args.steps // 2, args.steps}):
            cells = paths[step]
            at = values[tuple(cells.T)]
            loads = [cluster_loads(cells, at, p) for p in args.parts]
            print(f"| {n:,} | {step} | {loads[0][0]:,} | " + " | ".join(f"{b:.2f}" for _, b in loads) + " |")


if __name__ == "__main__":
    main()
