"""Time to first result: cold and warm `crowdmotion run` of every built-in scene, and its
simulation alone, side by side in one run (issue 16).

- cold: `crowdmotion run NAME` in a fresh process with an empty numba cache
  (``NUMBA_CACHE_DIR`` a new folder), as on a fresh install: every kernel the run uses is
  compiled, then every output (trajectories, summary, pictures, player) is written;
- warm: the same command again with the cache the cold run filled;
- bare: warm, with ``--plots none`` (trajectories and summary.json only);
- simulation: ``run_scenario`` alone, in a warm process (kernels loaded), best of 2.

    crowdmotion bench startup [--only NAME ...]
    python benchmarks/bench_startup.py [--only NAME ...]

Goals: cold <= 3x warm and warm <= 3x the simulation for every built-in scene.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SIMULATE = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
from crowdmotion.scenario import load_scenario, run_scenario
from crowdmotion.cli import scenario_path
sc = load_scenario(scenario_path(sys.argv[1]))
run_scenario(sc, progress=False)  # load the cached kernels
best = float("inf")
for _ in range(2):
    t = time.perf_counter()
    run_scenario(sc, progress=False)
    best = min(best, time.perf_counter() - t)
print(json.dumps(best))
"""


def _timed(cmd: list[str], env: dict) -> float:
    t = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - t


def measure(name: str, root: Path) -> dict:
    """Cold, warm and simulation-only seconds for one built-in scene."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(root / "numba" / name))
    run = [sys.executable, "-m", "crowdmotion.cli", "run", name, "-o", str(root / "out" / name), "--overwrite", "-q"]
    cold = _timed(run, env)
    warm = _timed(run, env)
    bare = _timed(run + ["--plots", "none"], env)
    done = subprocess.run([sys.executable, "-c", SIMULATE, name], env=env, capture_output=True, text=True, check=True)
    sim = json.loads(done.stdout.strip().splitlines()[-1])
    return {"scene": name, "cold_s": cold, "warm_s": warm, "bare_s": bare, "simulation_s": sim}


def table(rows: list[dict]) -> str:
    out = ["| scene | cold run | warm run | warm, --plots none | simulation | cold / warm | warm / simulation |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        cw, ws = r["cold_s"] / r["warm_s"], r["warm_s"] / r["simulation_s"]
        out.append(f"| {r['scene']} | {r['cold_s']:.1f} s | {r['warm_s']:.1f} s | {r['bare_s']:.1f} s | "
                   f"{r['simulation_s']:.2f} s | {cw:.1f}x{'' if cw <= 3 else ' (goal <= 3)'} | "
                   f"{ws:.1f}x{'' if ws <= 3 else ' (goal <= 3)'} |")
    return "\n".join(out)


def main(argv=None) -> None:
    from crowdmotion.cli import builtin_scenarios

    ap = argparse.ArgumentParser(prog="crowdmotion bench startup", description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="*", help="built-in scene names (default: all)")
    args = ap.parse_args(argv)
    names = [p.stem for p in builtin_scenarios()]
    unknown = sorted(set(args.only or []) - set(names))
    if unknown:
        ap.error(f"unknown built-in scene(s) {unknown}; see `crowdmotion scenarios`")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in (args.only or names):
            rows.append(measure(name, Path(tmp)))
            r = rows[-1]
            print(f"{name}: cold {r['cold_s']:.1f} s, warm {r['warm_s']:.1f} s, bare {r['bare_s']:.1f} s, "
                  f"simulation {r['simulation_s']:.2f} s", file=sys.stderr, flush=True)
    print(table(rows))


if __name__ == "__main__":
    main()
