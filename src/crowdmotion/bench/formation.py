"""Formation benchmark: the paper's Table 1 (group exchange at 1000 / 2000 / 3000 agents)
extended to 10,000 and 100,000, side by side in one run.

Two square blocks of n/2 agents (spacing 1.2 m, radius 0.3 m) start 4 m apart and walk
past each other, offset sideways by 90 % of their width so that their outer ranks meet:
each group is a moving obstacle to the other, so from the first steps vertices enter the
other group's field, become handles and the meshes bend round each other. (Blocks meeting
more squarely are a poor test: each sees the other as one disc and both must swerve by
most of their width; see docs/formation.md.) For each size:

- mesh generation: the Delaunay formation meshes of both groups (best of 3);
- deformation per step: the mesh stage of a step (field lookup, tearing, the two-step
  ARAP solve and the vertex update) for both groups, mean over the measured steps;
- full step: everything (mesh stage, attraction-point guidance, safety passes);
- baseline: the same simulation with the factorisation cache switched off, so the two
  ARAP systems are refactorised at every step (what a plain implementation does).

    crowdmotion bench formation [--sizes 1000 2000 3000 10000 100000] [--steps 40]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from crowdmotion import Scene
from crowdmotion.formation import FormationMesh, Simulator, block

PAPER = {1000: (35, 20.15), 2000: (78, 39.44), 3000: (254, 94.56)}
SPACING, RADIUS = 1.2, 0.3


def exchange(n: int, cache: bool, cell: float):
    side = int(np.ceil(np.sqrt(n / 2)))
    rows, cols = side, int(np.ceil(n / 2 / side))
    width = (max(rows, cols) - 1) * SPACING
    gap = 4.0
    ax, bx = 0.0, width + gap
    off = 0.9 * width
    scene = Scene(((-width - 20, -2 * width - 20), (3 * width + 40, 2 * width + 20)))
    sim = Simulator(scene, time_step=0.1, field_cell=cell, max_steps=10**6)
    sim.add_group(block(rows, cols, SPACING), goal=(bx + width, off / 2), start=(ax, off / 2), heading=0.0,
                  radius=RADIUS)
    sim.add_group(block(rows, cols, SPACING), goal=(ax - width, -off / 2), start=(bx, -off / 2), heading=np.pi,
                  radius=RADIUS)
    if not cache:
        for g in sim.groups:
            g.solver.cache_size = 0
    return sim


def timed_steps(sim: Simulator, steps: int) -> tuple[float, float, float]:
    """(mean full step s, mean mesh stage s, mean handles per step)."""
    spent = [0.0]
    inner = sim._advance_mesh

    def advance(*a):
        t = time.perf_counter()
        inner(*a)
        spent[0] += time.perf_counter() - t

    sim._advance_mesh = advance
    handles = 0
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
        handles += sum(g.handles for g in sim.groups)
    full = (time.perf_counter() - t0) / steps
    return full, spent[0] / steps, handles / steps


def mesh_time(n: int, repeats: int = 3) -> float:
    side = int(np.ceil(np.sqrt(n / 2)))
    pts = block(side, int(np.ceil(n / 2 / side)), SPACING).points
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        FormationMesh(pts)
        FormationMesh(pts + 1000.0)
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="crowdmotion bench formation")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 3000, 10000, 100000])
    ap.add_argument("--steps", type=int, default=40, help="measured steps (fewer above 10,000 agents)")
    args = ap.parse_args(argv)
    exchange(200, True, 0.25).step()  # compile the kernels
    print("| agents | mesh generation | deformation / step | full step | factorisations | baseline: refactorise "
          "every step (deformation / full) | speed-up (deformation) | paper (mesh / deformation) |")
    print("|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        steps = args.steps if n <= 10000 else max(5, args.steps // 8)
        cell = 0.25 if n <= 10000 else 1.0
        tm = mesh_time(n)
        sim = exchange(n, True, cell)
        for _ in range(3):  # the first factorisations are part of the set-up
            sim.step()
        full, deform, handles = timed_steps(sim, steps)
        facts = sum(g.solver.stats["factorisations"] for g in sim.groups)
        base = exchange(n, False, cell)
        for _ in range(3):
            base.step()
        b_full, b_deform, _ = timed_steps(base, max(3, steps // 4))
        paper = PAPER.get(n)
        ptxt = f"{paper[0]} ms / {paper[1]} ms" if paper else "-"
        print(f"| {len(sim.positions):,} | {tm * 1e3:.1f} ms | {deform * 1e3:.2f} ms | {full * 1e3:.2f} ms | "
              f"{facts} in {steps + 3} steps ({handles:.0f} handles/step) | {b_deform * 1e3:.1f} ms / "
              f"{b_full * 1e3:.1f} ms | {b_deform / deform:.1f}x | {ptxt} |", flush=True)


if __name__ == "__main__":
    main()
