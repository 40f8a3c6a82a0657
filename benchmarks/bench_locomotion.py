"""What the locomotion channels cost a `crowdmotion run` of each built-in scene, beside its
simulation (issue 31's goal: channels <= 10 % of the simulation time).

For each built-in scene, in one warm process (each scene simulated once first, so its
kernels are loaded):

- simulation: ``run_scenario`` (what `crowdmotion run` does before writing), best of
  ``--repeats``;
- channels: ``crowdmotion.locomotion.locomotion`` on the run's trajectories, as the
  writers and the player call it, best of ``--repeats`` (the facing, which every file
  carries with or without the channels, is derived before timing);
- in the run: the run's files written as `crowdmotion run` writes them (its own
  ``[output] formats`` and the player page, in this process), under cProfile: how often
  the channels are computed and the seconds spent in them.

    python benchmarks/bench_locomotion.py [--only NAME ...] [--repeats 3] [--json out.json]

Prints a Markdown table (docs/performance.md, *Locomotion channels*).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import sys
import tempfile
import time
import warnings
from pathlib import Path


def best_of(repeats: int, fn) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def in_the_run(result, out: Path) -> tuple[int, float]:
    """(calls, seconds) of the channels while the run's files are written as `crowdmotion
    run` writes them: its formats, summary.json and the player page (the other pictures
    do not use the channels)."""
    from crowdmotion.outputs import write_run

    prof = cProfile.Profile()
    prof.enable()
    write_run(result, out, plots=["player"])
    prof.disable()
    stats = pstats.Stats(prof).stats
    calls, seconds = 0, 0.0
    for (file, _, name), (_, ncalls, _, cumtime, _) in stats.items():
        if name == "locomotion" and file.endswith("crowdmotion/locomotion.py"):
            calls, seconds = ncalls, cumtime
    return calls, seconds


def measure(path: Path, repeats: int, root: Path) -> dict:
    from crowdmotion.locomotion import locomotion
    from crowdmotion.scenario import load_scenario, run_scenario

    sc = load_scenario(path)
    run_scenario(sc, progress=False)  # kernels loaded (compiled on a cold cache)
    sim, result = best_of(repeats, lambda: run_scenario(sc, progress=False))
    traj = result.trajectories
    traj.facing  # noqa: B018  derived once: every file carries it, channels or not
    loco_s, _ = best_of(repeats, lambda: locomotion(traj))
    calls, run_s = in_the_run(result, root / path.stem)
    return {"scene": path.stem, "method": sc.method, "frames": traj.n_frames, "agents": traj.n_agents,
            "simulation_s": sim, "channels_s": loco_s, "calls": calls, "in_run_s": run_s,
            "formats": list(sc.spec.output.formats)}


def table(rows: list[dict]) -> str:
    out = ["| scene | frames x agents | simulation | channels, one call | calls in a run | channels in the run "
           "| share of the simulation |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        share = r["in_run_s"] / r["simulation_s"]
        mark = " (goal <= 10 %)" if share > 0.10 else ""
        out.append(f"| {r['scene']} | {r['frames']} x {r['agents']} | {r['simulation_s']:.3f} s | "
                   f"{r['channels_s'] * 1000:.1f} ms | {r['calls']} | {r['in_run_s'] * 1000:.1f} ms | "
                   f"{100 * share:.1f} %{mark} |")
    return "\n".join(out)


def main(argv=None) -> None:
    from crowdmotion.builtin import builtin_scenarios

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", metavar="NAME", help="these built-in scenes only")
    ap.add_argument("--repeats", type=int, default=3, help="timings per measure (best taken)")
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    scenes = [p for p in builtin_scenarios() if not args.only or p.stem in args.only]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in scenes:
            rows.append(measure(path, args.repeats, Path(tmp)))
            r = rows[-1]
            print(f"{r['scene']}: simulation {r['simulation_s']:.3f} s, channels {r['channels_s'] * 1000:.1f} ms "
                  f"x {r['calls']} in the run ({r['in_run_s'] * 1000:.1f} ms)", file=sys.stderr, flush=True)
    print(f"{os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}")
    print(table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
