"""Where the RVO step's time goes: the open-scene benchmark's simulator (``crowdmotion
bench rvo``'s circle or crossing), each part of the step timed round its call with
``time.perf_counter`` over ``--steps`` steps after a few untimed ones; prints ms a step
per part (indented: the kernel inside the part above it).

    python benchmarks/rvo_step_parts.py [--agents 10000] [--shape circle] [--steps 20]
"""

from __future__ import annotations

import argparse
import collections
import time

import numpy as np

from crowdmotion.bench import rvo as bench
from crowdmotion.rvo import _kernels as K
from crowdmotion.rvo import deadlock, density, lanes, simulator

PARTS = [  # (owner, attribute, label)
    (simulator.Simulator, "_guidance", "guidance"),
    (simulator.Simulator, "_grid", "grid of the agents"),
    (density.DensitySlowing, "factors", "density sensed ahead"),
    (K, "density_ahead", "  kernel density_ahead"),
    (deadlock.Deadlock, "yielding_velocities", "yielders' velocities"),
    (lanes.LaneChoice, "velocities", "lane choice"),
    (K, "lane_choice", "  kernel lane_choice"),
    (simulator.Simulator, "_turned_in", "turning in to the goal"),
    (K, "choose_velocities", "choosing velocities (kernel)"),
    (K, "resolve_conflicts", "safety pass (kernel)"),
    (deadlock.Deadlock, "update", "stand-off rules"),
    (simulator.Simulator, "_arrivals", "arrivals"),
]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=10000)
    ap.add_argument("--shape", choices=("circle", "crossing"), default="circle")
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args(argv)
    pos, goal = bench.lattice(args.agents, np.random.default_rng(1), args.shape)
    sim = bench.open_simulator(pos, goal)
    for _ in range(3):
        sim.step()
    spent = collections.defaultdict(float)
    originals = [(owner, name, getattr(owner, name)) for owner, name, _ in PARTS]
    for (owner, name, fn), (_, _, label) in zip(originals, PARTS):

        def timed(*a, _fn=fn, _label=label, **kw):
            t0 = time.perf_counter()
            try:
                return _fn(*a, **kw)
            finally:
                spent[_label] += time.perf_counter() - t0

        setattr(owner, name, timed)
    try:
        t0 = time.perf_counter()
        for _ in range(args.steps):
            sim.step()
        step = (time.perf_counter() - t0) / args.steps
    finally:
        for owner, name, fn in originals:
            setattr(owner, name, fn)
    print(f"{args.shape}, {args.agents:,} agents: {step * 1e3:.1f} ms a step")
    for _, _, label in PARTS:
        ms = spent[label] / args.steps * 1e3
        print(f"  {label:32s} {ms:6.2f} ms  {ms / (step * 1e3):5.1%}")

if __name__ == "__main__":
    main()
