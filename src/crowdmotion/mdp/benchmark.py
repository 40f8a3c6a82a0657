"""The paper's Tables 1 and 2 (§3.1): solver timings on its ten grids, beside ours and scipy's."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from crowdmotion.mdp.solvers import (csgraph_values, dijkstra, dijkstra_unsorted, fast_values,
                                     heuristic_value_iteration, improved_value_iteration)

# (shape, goal, obstacle slice lower corner, upper corner inclusive), paper §3.1
PAPER_GRIDS = [
    ((10, 10), (9, 5), (5, 3), (5, 7)),
    ((20, 20), (19, 10), (10, 5), (10, 14)),
    ((30, 30), (29, 15), (15, 10), (15, 19)),
    ((40, 40), (39, 20), (20, 15), (20, 24)),
    ((50, 50), (49, 25), (25, 20), (25, 29)),
    ((10, 10, 10), (9, 5, 5), (5, 3, 3), (5, 7, 7)),
    ((20, 20, 20), (19, 10, 10), (10, 5, 5), (10, 14, 14)),
    ((30, 20, 30), (29, 10, 15), (15, 5, 10), (15, 14, 19)),
    ((40, 20, 40), (39, 10, 20), (20, 5, 15), (20, 14, 24)),
    ((50, 20, 50), (49, 10, 25), (25, 5, 20), (25, 14, 29)),
]

# Tables 1 and 2: seconds, Python, i5-4590: IVI, HVI, Dijkstra
PAPER_SECONDS = {
    (10, 10): (0.0066, 0.0147, 0.0072),
    (20, 20): (0.0258, 0.0937, 0.0247),
    (30, 30): (0.0625, 0.2619, 0.1171),
    (40, 40): (0.1069, 0.5946, 0.3280),
    (50, 50): (0.1605, 1.0872, 0.7309),
    (10, 10, 10): (0.1791, 0.3925, 0.2024),
    (20, 20, 20): (1.6817, 5.2878, 7.7723),
    (30, 20, 30): (3.9912, 14.4246, 37.3508),
    (40, 20, 40): (7.1431, 30.9954, 114.8624),
    (50, 20, 50): (10.9903, 54.5086, 277.3717),
}


def paper_grid(shape, lower, upper) -> np.ndarray:
    """A free grid with the paper's wall (2D) or plane (3D) of obstacle cells."""
    g = np.zeros(shape, dtype=np.uint8)
    g[tuple(slice(lo, hi + 1) for lo, hi in zip(lower, upper))] = 1
    return g


def timed_runs(fn, repeats: int) -> tuple[list[float], object]:
    """Wall time of each of ``repeats`` runs, and the last result."""
    out = None
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        t.append(time.perf_counter() - t0)
    return t, out


def timed(fn, repeats: int) -> tuple[float, object]:
    """Mean wall time over ``repeats`` runs (the paper averaged 3) and the last result."""
    t, out = timed_runs(fn, repeats)
    return float(np.mean(t)), out


@dataclass
class BenchRow:
    shape: tuple
    seconds: dict = field(default_factory=dict)  # solver -> mean seconds
    max_error: dict = field(default_factory=dict)  # solver -> max |v - exact| over reachable cells


def run_paper_tables(reference: bool = True, repeats: int = 3, progress: bool = True,
                     grids=PAPER_GRIDS) -> list[BenchRow]:
    """Time every solver on the paper's grids (corner cutting on, as the paper)."""
    fast_values(np.zeros((3, 3), np.uint8), [(0, 0)])  # compile (or load) outside the timing
    fast_values(np.zeros((3, 3, 3), np.uint8), [(0, 0, 0)])
    rows = []
    for shape, goal, lo, hi in tqdm(grids, desc="paper grids", disable=not progress):
        grid = paper_grid(shape, lo, hi)
        row = BenchRow(shape)
        row.seconds["fast"], exact = timed(lambda: fast_values(grid, [goal]), max(repeats, 5))
        row.seconds["scipy"], ref = timed(lambda: csgraph_values(grid, [goal]), repeats)
        reach = np.isfinite(exact)
        row.max_error["scipy"] = float(np.max(np.abs(ref[reach] - exact[reach])))
        if reference:
            for name, fn in (("ivi", lambda: improved_value_iteration(grid, [goal])[0]),
                             ("hvi", lambda: heuristic_value_iteration(grid, [goal])[0]),
                             ("dijkstra", lambda: dijkstra(grid, [goal])),
                             ("dijkstra_unsorted", lambda: dijkstra_unsorted(grid, [goal]))):
                row.seconds[name], v = timed(fn, repeats)
                row.max_error[name] = float(np.max(np.abs(v[reach] - exact[reach])))
        rows.append(row)
    return rows


def format_tables(rows: list[BenchRow]) -> str:
    """Markdown table: paper seconds, ours, the paper's ranking of Dijkstra against IVI
    beside ours (unsorted Dijkstra / IVI), and fast's speed-up over each."""
    lines = ["| grid | paper IVI / HVI / Dijkstra (s) | ref IVI | ref HVI | ref Dijkstra, heap | "
             "ref Dijkstra, unsorted | Dijkstra / IVI, paper vs unsorted vs heap | scipy csgraph | fast | "
             "fast vs ref IVI | fast vs scipy | max error IVI / HVI |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = PAPER_SECONDS.get(tuple(r.shape))
        paper = " / ".join(f"{x:g}" for x in p) if p else "-"
        s = r.seconds
        f = s["fast"]

        def cell(k):
            return f"{s[k]:.4f}" if k in s else "-"

        vs_ivi = f"{s['ivi'] / f:,.0f}x" if "ivi" in s else "-"
        rank = "-"
        if p and "ivi" in s and "dijkstra_unsorted" in s:
            rank = f"{p[2] / p[0]:.1f} / {s['dijkstra_unsorted'] / s['ivi']:.1f} / {s['dijkstra'] / s['ivi']:.1f}"
        err = (f"{r.max_error['ivi']:.3f} / {r.max_error['hvi']:.3f}" if "ivi" in r.max_error else "-")
        lines.append(f"| {'x'.join(map(str, r.shape))} | {paper} | {cell('ivi')} | {cell('hvi')} | "
                     f"{cell('dijkstra')} | {cell('dijkstra_unsorted')} | {rank} | {cell('scipy')} | "
                     f"{f * 1e3:.3f} ms | {vs_ivi} | "
                     f"{s['scipy'] / f:,.0f}x | {err} |")
    return "\n".join(lines)


def print_tables(rows: list[BenchRow]) -> None:
    print("MDP solvers on the paper's grids (Liu & Du 2019, Tables 1-2); seconds, mean of repeats")
    print(format_tables(rows))
