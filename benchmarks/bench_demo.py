"""The demo and verify on every core against one after another, side by side in one run.

    python benchmarks/bench_demo.py [--rounds 2] [--jobs N] [--only SCENE ...] [--no-verify]

Each round, in fresh processes and alternating: `crowdmotion demo -j 1` and
`crowdmotion demo -j N` (N: --jobs, default what the demo itself picks), each cold (an
empty numba cache, as on a fresh install) and then warm (the cache that cold run filled);
then `crowdmotion verify -j 1` and `-j N`, warm. Prints medians and ranges over the
rounds, and the ratio of the parallel time to the serial one.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

from crowdmotion.bench.startup import timed_run as timed


def main(argv=None) -> None:
    from crowdmotion.workers import default_jobs

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2, help="interleaved rounds (default 2)")
    ap.add_argument("--jobs", type=int, default=default_jobs(), help="the parallel runs' -j (default: the demo's own)")
    ap.add_argument("--only", nargs="*", help="demo: only these built-in scenes")
    ap.add_argument("--no-verify", action="store_true", help="time the demo only")
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.jobs < 1:
        ap.error("--rounds and --jobs must be at least 1")
    cli = [sys.executable, "-m", "crowdmotion.cli"]
    only = ["--only", *args.only] if args.only else []
    got: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for jobs in (1, args.jobs):
                env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(dir=tmp))
                for state in ("cold", "warm"):
                    out = Path(tmp) / f"demo-{r}-{jobs}-{state}"
                    got.setdefault(f"demo, {state}, -j {jobs}", []).append(
                        timed(cli + ["demo", "-q", "-o", str(out), "-j", str(jobs), *only], env))
                if not args.no_verify:
                    got.setdefault(f"verify, warm, -j {jobs}", []).append(
                        timed(cli + ["verify", "-q", "-o", str(Path(tmp) / f"verify-{r}-{jobs}"), "-j", str(jobs)],
                              env))
                print(", ".join(f"{k}: {v[-1]:.1f} s" for k, v in got.items() if f"-j {jobs}" in k),
                      file=sys.stderr, flush=True)

    def cell(values: list[float]) -> str:
        return f"{statistics.median(values):.1f} s ({min(values):.1f}-{max(values):.1f})"

    print(f"| run | -j 1 | -j {args.jobs} | ratio |")
    print("|---|---|---|---|")
    for what in ("demo, cold", "demo, warm") + (() if args.no_verify else ("verify, warm",)):
        one, many = got[f"{what}, -j 1"], got[f"{what}, -j {args.jobs}"]
        print(f"| {what} | {cell(one)} | {cell(many)} | {statistics.median(many) / statistics.median(one):.2f}x |")


if __name__ == "__main__":
    main()
