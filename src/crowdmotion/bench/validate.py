"""Validate benchmark: how long ``crowdmotion validate`` takes to refuse a run too large
for memory, against the number of agents, beside a full validation that places them.

The size estimate is made from the groups' counts and the method's parameters alone, so
refusing a run that would not fit takes the same time for ten thousand agents as for ten
million; a scenario that fits is then checked in full (RVO places every agent and builds
its guidance), which grows with the count. One RVO scene: a 3 km x 2 km field, one group
spawning over most of it, a point goal; ``--max-memory`` set just below the estimate
for the refusals.

    crowdmotion bench validate [--sizes 10000 100000 1000000 10000000] [--full 10000 100000 1000000]
"""

from __future__ import annotations

import argparse
import time

from crowdmotion.scenario import ScenarioError, parse_scenario, size_estimate

SCENE = """
name = "bench"
method = "rvo"
[scene]
bounds = [[0, 0], [3000, 2000]]
[[groups]]
name = "crowd"
count = {count}
spawn = {{ shape = "rect", lower = [10, 10], upper = [2900, 1990] }}
goal = {{ shape = "point", position = [2990, 1000] }}
"""


def _timed(text: str, max_memory: int | None) -> tuple[float, bool]:
    t0 = time.perf_counter()
    try:
        parse_scenario(text, "bench", max_memory=max_memory)
        refused = False
    except ScenarioError:
        refused = True
    return time.perf_counter() - t0, refused


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="crowdmotion bench validate")
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000, 10_000_000],
                    help="agents in the scenarios refused for memory")
    ap.add_argument("--full", type=int, nargs="+", default=[10_000, 100_000, 1_000_000],
                    help="agents in the scenarios validated in full (placed)")
    args = ap.parse_args(argv)
    parse_scenario(SCENE.format(count=10), "warm-up")  # imports and compiles once
    print("| agents | estimate | refused (max-memory below the estimate) | validated in full |")
    print("|---|---|---|---|")
    for n in sorted(set(args.sizes) | set(args.full)):
        text = SCENE.format(count=n)
        est = size_estimate(parse_scenario(SCENE.format(count=10), "estimate"))
        bytes_ = est.bytes // 10 * n
        refused = "-"
        if n in args.sizes:
            seconds, ok = _timed(text, max(1, bytes_ - 1))
            refused = f"{seconds * 1e3:.1f} ms" + ("" if ok else " (not refused!)")
        full = "-"
        if n in args.full:
            seconds, bad = _timed(text, bytes_ * 2)
            full = f"{seconds:.2f} s" + (" (refused)" if bad else "")
        print(f"| {n:,} | {bytes_ / 2**30:.2f} GiB | {refused} | {full} |", flush=True)


if __name__ == "__main__":
    main()
