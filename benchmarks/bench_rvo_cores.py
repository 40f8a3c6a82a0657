"""How crowdmotion.rvo's step scales with cores, beside pyrvo (RVO2's ORCA, one thread).

One process steps the same scenes on 1, 2, 4, ... numba threads (``numba.set_num_threads``
up to ``NUMBA_NUM_THREADS``, by default the machine's cores):

- the open circle and crossing of ``crowdmotion bench rvo`` (jittered 1 m lattice, radius
  0.25 m) at each size: ms per whole step (guidance, density sensed ahead, lane choice,
  neighbours, the velocity choice, the safety pass, the stand-off rules, the move), mean
  of ``--steps`` steps after two untimed ones;
- the stand evacuation (``rvo_stand_evacuation``) with ``--stand`` people, run to the end:
  wall time of the stepping.

pyrvo's ``do_step`` on the same scenes (and its whole stand run, the Python loop setting
preferred velocities included) is timed once: it is single-threaded. Every thread count
must step to the same positions (the last column, a digest of the final positions, shows
it). The free cores the adaptive thread count sees (``crowdmotion._threads``) are printed
before each row: with other work on the machine our kernels use fewer threads than asked.

    python benchmarks/bench_rvo_cores.py [--threads 1 2 4 8 16] [--sizes 10000 40000]
                                         [--steps 20] [--stand 2000]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import time

import numba
import numpy as np

from crowdmotion import _threads
from crowdmotion.bench.rvo import lattice, open_simulator, pyrvo_stand, pyrvo_times, stand_simulator


def _digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:12]


def open_step(pos, goal, steps: int) -> tuple[float, str]:
    """(seconds per step, digest of the final positions) of our step on the open scene."""
    sim = open_simulator(pos, goal)
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps, _digest(sim.positions)


def stand_run(count: int) -> tuple[float, int, int, str]:
    """(wall seconds, steps, people out, digest) of our stand evacuation run to the end."""
    sim, params = stand_simulator(count)
    t0 = time.perf_counter()
    while sim.steps < params.max_steps and (sim.active & ~sim.arrived).any():
        sim.step()
    return time.perf_counter() - t0, sim.steps, int(sim.arrived.sum()), _digest(sim.positions)


def _free() -> str:
    return f"{_threads._free_cores.cores():.1f}" if _threads._free_cores else "not measured"


def main(argv=None) -> None:
    cap = numba.get_num_threads()
    ap = argparse.ArgumentParser(prog="bench_rvo_cores")
    ap.add_argument("--threads", type=int, nargs="+",
                    default=sorted({1, 2, 4, 8, 16, 32, 64} & set(range(1, cap + 1)) | {cap}))
    ap.add_argument("--sizes", type=int, nargs="*", default=[10000, 40000])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--stand", type=int, nargs="*", default=[2000])
    args = ap.parse_args(argv)
    bad = [t for t in args.threads if not 1 <= t <= cap]
    if bad:
        raise SystemExit(f"--threads {bad}: numba has {cap} threads here (NUMBA_NUM_THREADS); ask for 1 to {cap}")
    print(f"cores: {os.cpu_count()}, numba threads: {cap}, cores free of other work now: {_free()}", flush=True)

    rows = ["| scene | agents | pyrvo do_step (1 thread) | " + " | ".join(f"ours, {t} thr" for t in args.threads)
            + " | best ours / pyrvo | same positions on every thread count |",
            "|---|---|---|" + "---|" * len(args.threads) + "---|---|"]
    for shape in ("circle", "crossing"):
        for n in args.sizes:
            pos, goal = lattice(n, np.random.default_rng(1), shape)
            try:
                core, _ = pyrvo_times(pos, goal, args.steps)
            except ImportError:
                core = float("nan")
            times, digests = [], set()
            for t in args.threads:
                numba.set_num_threads(t)
                print(f"  {shape} {n}: {t} threads (free cores {_free()})", flush=True)
                s, d = open_step(pos, goal, args.steps)
                times.append(s)
                digests.add(d)
            numba.set_num_threads(cap)
            rows.append(f"| {shape} | {n:,} | {core * 1e3:.1f} ms | " + " | ".join(f"{s * 1e3:.1f} ms" for s in times)
                        + f" | {min(times) / core:.2f}x | {'yes' if len(digests) == 1 else 'NO: ' + str(digests)} |")
            print(rows[-1], flush=True)
    for count in args.stand:
        try:
            peer = pyrvo_stand(count)
            peer_s = f"{peer['wall']:.2f} s whole loop ({peer['core']:.2f} s do_step)"
            peer_wall = peer["wall"]
        except ImportError:
            peer_s, peer_wall = "not installed", float("nan")
        stand_simulator(100)[0].step()  # compile what the stand's scene adds
        times, digests, outs = [], set(), set()
        for t in args.threads:
            numba.set_num_threads(t)
            print(f"  stand {count}: {t} threads (free cores {_free()})", flush=True)
            wall, steps, out, d = stand_run(count)
            times.append(wall)
            digests.add(d)
            outs.add(out)
        numba.set_num_threads(cap)
        rows.append(f"| stand evacuation, whole run | {count:,} ({', '.join(map(str, sorted(outs)))} out) | {peer_s} | "
                    + " | ".join(f"{s:.2f} s" for s in times)
                    + f" | {min(times) / peer_wall:.2f}x | {'yes' if len(digests) == 1 else 'NO: ' + str(digests)} |")
        print(rows[-1], flush=True)
    print()
    print("\n".join(rows))


if __name__ == "__main__":
    main()
