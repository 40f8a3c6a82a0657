"""Time to first result: cold and warm `crowdmotion run` of every built-in scene, and its
simulation alone, side by side in one run (issue 16).

- cold: `crowdmotion run NAME` in a fresh process with an empty numba cache
  (``NUMBA_CACHE_DIR`` a new folder), as on a fresh install: every kernel the run uses is
  compiled, then every output (trajectories, summary, pictures, player) is written;
- warm: the same command again with the cache the cold run filled;
- bare: warm, with ``--plots none`` (trajectories and summary.json only);
- simulation: ``run_scenario`` alone, in a warm process (kernels loaded), best of 2.

    crowdmotion bench startup [--only NAME ...] [--rounds N]   # N rounds: median times
    python benchmarks/bench_startup.py [--only NAME ...]
    crowdmotion bench startup --baseline-src OLD/src --rounds 3 --only rvo_street_O ...

With ``--baseline-src`` (another checkout's ``src`` folder) each scene's cold and warm
runs alternate between that code (on ``PYTHONPATH``) and this install, ``--rounds``
times, and the table gives medians and ranges: a before/after that one slow minute of a
shared machine cannot tilt.

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


def timed_run(cmd: list[str], env: dict) -> float:
    """Wall seconds of a command run to the end; its stderr's tail if it fails."""
    t = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - t


def _run_command(name: str, root: Path) -> list[str]:
    """``crowdmotion run NAME`` as the benchmark times it: quiet, into ``root``/out/NAME."""
    return [sys.executable, "-m", "crowdmotion.cli", "run", name, "-o", str(root / "out" / name), "--overwrite", "-q"]


def measure(name: str, root: Path) -> dict:
    """Cold, warm and simulation-only seconds for one built-in scene (on a new cache)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(dir=root, prefix=f"numba-{name}-"))
    run = _run_command(name, root)
    cold = timed_run(run, env)
    warm = timed_run(run, env)
    bare = timed_run(run + ["--plots", "none"], env)
    done = subprocess.run([sys.executable, "-c", SIMULATE, name], env=env, capture_output=True, text=True, check=True)
    sim = json.loads(done.stdout.strip().splitlines()[-1])
    return {"scene": name, "cold_s": cold, "warm_s": warm, "bare_s": bare, "simulation_s": sim}


def cold_and_warm(name: str, root: Path, src: str | None) -> tuple[float, float]:
    """One cold and one warm run of a scene, on a new cache; ``src`` on PYTHONPATH."""
    env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(dir=root))
    env.pop("PYTHONPATH", None)
    if src:
        env["PYTHONPATH"] = src
    # each code into its own folder: an older version's files (no manifest.json) are not
    # this version's to overwrite
    run = _run_command(name, root / ("baseline" if src else "current"))
    return timed_run(run, env), timed_run(run, env)


def compare(names: list[str], baseline_src: str, rounds: int, root: Path) -> str:
    """Interleaved cold/warm runs of the baseline and this code: medians and ranges."""
    import statistics

    got: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for _ in range(rounds):
        for name in names:
            for tag, src in (("before", baseline_src), ("now", None)):
                got.setdefault((name, tag), []).append(cold_and_warm(name, root, src))
                print(f"{name} {tag}: cold {got[name, tag][-1][0]:.1f} s, warm {got[name, tag][-1][1]:.1f} s",
                      file=sys.stderr, flush=True)

    def cell(values: list[float]) -> str:
        return f"{statistics.median(values):.1f} ({min(values):.1f}-{max(values):.1f})"

    out = ["| scene | cold: before → now | warm: before → now |", "|---|---|---|"]
    for name in names:
        b, n = got[name, "before"], got[name, "now"]
        out.append(f"| {name} | {cell([x[0] for x in b])} → {cell([x[0] for x in n])} s | "
                   f"{cell([x[1] for x in b])} → {cell([x[1] for x in n])} s |")
    return "\n".join(out)


def medians(rounds: list[list[dict]]) -> list[dict]:
    """Each scene's measures over rounds (lists of :func:`measure` rows in one order):
    the median of each column, and ``rounds``: how many."""
    import statistics

    keys = ("cold_s", "warm_s", "bare_s", "simulation_s")
    return [{"scene": rows[0]["scene"], "rounds": len(rows), **{k: statistics.median(r[k] for r in rows) for k in keys}}
            for rows in zip(*rounds)]


def table(rows: list[dict]) -> str:
    """The markdown table of :func:`measure` rows (or their :func:`medians`); the ratios
    are of the (median) times."""
    out = ["| scene | cold run | warm run | warm, --plots none | simulation | cold / warm | warm / simulation |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        cw, ws = r["cold_s"] / r["warm_s"], r["warm_s"] / r["simulation_s"]
        out.append(f"| {r['scene']} | {r['cold_s']:.1f} s | {r['warm_s']:.1f} s | {r['bare_s']:.1f} s | "
                   f"{r['simulation_s']:.2f} s | {cw:.1f}x{'' if cw <= 3 else ' (goal <= 3)'} | "
                   f"{ws:.1f}x{'' if ws <= 3 else ' (goal <= 3)'} |")
    return "\n".join(out)


def main(argv=None) -> None:
    from crowdmotion.builtin import builtin_scenarios

    ap = argparse.ArgumentParser(prog="crowdmotion bench startup", description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="*", help="built-in scene names (default: all)")
    ap.add_argument("--baseline-src", help="another checkout's src folder: interleave its cold and warm runs with "
                                           "this code's (medians and ranges over --rounds)")
    ap.add_argument("--rounds", type=int, help="rounds: of the interleaved comparison (default 3), or of the "
                                               "table, whose times are then medians (default 1)")
    args = ap.parse_args(argv)
    names = [p.stem for p in builtin_scenarios()]
    unknown = sorted(set(args.only or []) - set(names))
    if unknown:
        ap.error(f"unknown built-in scene(s) {unknown}; see `crowdmotion scenarios`")
    if args.rounds is not None and args.rounds < 1:
        ap.error(f"--rounds {args.rounds}: must be at least 1")
    if args.baseline_src:
        if not (Path(args.baseline_src) / "crowdmotion").is_dir():
            ap.error(f"--baseline-src {args.baseline_src}: no crowdmotion package in that folder")
        with tempfile.TemporaryDirectory() as tmp:
            print(compare(args.only or names, str(Path(args.baseline_src).resolve()), args.rounds or 3, Path(tmp)))
        return
    rounds = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.rounds or 1):  # every scene once per round: a slow minute touches one round
            rounds.append([])
            for name in (args.only or names):
                rounds[-1].append(measure(name, Path(tmp)))
                r = rounds[-1][-1]
                print(f"round {k + 1}, {name}: cold {r['cold_s']:.1f} s, warm {r['warm_s']:.1f} s, "
                      f"bare {r['bare_s']:.1f} s, simulation {r['simulation_s']:.2f} s", file=sys.stderr, flush=True)
    print(table(medians(rounds)))


if __name__ == "__main__":
    main()
