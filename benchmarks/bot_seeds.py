"""The FZJ BOT-360 counterflow runs rebuilt (`crowdmotion verify --empirical`'s
counterflow_lanes case) over many seeds: how often the speed lands within 0.2 m/s of the
measured run at the nearest density, and whether everyone leaves in every run.

The verify case runs the three entrance widths (0.9, 1.6 and 2.5 m) with seeds 0-2; this
runs each of those nine with its seed offset by every value of ``--offsets`` (the figures
of docs/verification.md: offsets 0-500, then 600-1500). Each run is measured as the case
measures it (density and speed in the 2 m area mid-corridor, lane order), and the share
of walkers keeping to their own right half of the corridor in its middle (x 12-14 m) is
printed beside it: runs whose lanes formed on the right are nearer the data.

    python benchmarks/bot_seeds.py     # offsets 0, 100, ... 500: 54 runs, about 1 min on 2 cores
    python benchmarks/bot_seeds.py --offsets 600 700 800 900 1000 1100 1200 1300 1400 1500
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from crowdmotion import empirical as E
from crowdmotion.cases import simulate

WITHIN = 0.2  # m/s: the verify case's tolerance
MIDDLE = (12.0, 14.0)  # x range where the lanes' sides are read
CENTRE_Y = 1.8  # the corridor's centre line (3.6 m wide from y 0)


def _run(job: tuple[str, int]) -> tuple[str, int, float, float, float, float, float, float]:
    """(setting, seed, density, speed, error against the nearest FZJ run, lane order ratio,
    share of walkers out, share keeping right mid-corridor) of one run."""
    name, seed = job
    out = simulate("rvo", E._bot("rvo")[name], seed=seed)
    rho, v, order, shuffled = E.bot_measures(out.traj, np.random.default_rng(0))
    ref = min(E.BOT_360_RUNS, key=lambda r: abs(r[0] - rho))
    tr = out.traj
    east = np.char.startswith(tr.group.astype(str), "east")
    x, y = tr.positions[..., 0], tr.positions[..., 1]
    middle = tr.active_mask & (x >= MIDDLE[0]) & (x <= MIDDLE[1])
    right = np.where(east[None, :], y < CENTRE_Y, y > CENTRE_Y)  # bound east, the right is south
    keeping_right = float((right & middle).sum() / max(middle.sum(), 1))
    return name, seed, rho, v, v - ref[1], order / shuffled, float(out.summary["arrival_rate"]), keeping_right


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--offsets", type=int, nargs="+", default=list(range(0, 600, 100)),
                    help="seed offsets added to each of the case's seeds 0-2 (default 0 100 ... 500)")
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1,
                    help="runs side by side (default: one per core)")
    args = ap.parse_args(argv)
    jobs = [(name, seed + off) for name in E._bot("rvo") for off in args.offsets for seed in (0, 1, 2)]
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        rows = list(pool.map(_run, jobs))
    err = np.array([r[4] for r in rows])
    print(f"{len(rows)} runs: speed within {WITHIN} m/s of the FZJ run at the nearest density in "
          f"{int(np.sum(np.abs(err) <= WITHIN))} (mean absolute error {np.mean(np.abs(err)):.3f} m/s, errors "
          f"{err.min():+.2f} to {err.max():+.2f}); lane order {np.mean([r[5] for r in rows]):.2f} times shuffled")
    for name in E._bot("rvo"):
        e = np.array([r[4] for r in rows if r[0] == name])
        print(f"  {name}: {int(np.sum(np.abs(e) <= WITHIN))} of {len(e)} within, "
              f"mean absolute error {np.mean(np.abs(e)):.3f}")
    share = np.array([r[7] for r in rows])
    ok = np.abs(err) <= WITHIN
    print(f"  keeping to their right mid-corridor (share over 0.6): {int(np.sum(share > 0.6))} runs, "
          f"{int(np.sum(ok & (share > 0.6)))} of them within; the others {int(np.sum(ok & (share <= 0.6)))} of "
          f"{int(np.sum(share <= 0.6))}")
    stuck = [(r[0], r[1], r[6]) for r in rows if r[6] < 1.0]
    print("  everyone left in every run" if not stuck else
          "  not everyone left: " + "; ".join(f"{n} seed {s}: {a:.0%} out" for n, s, a in stuck))


if __name__ == "__main__":
    main()
