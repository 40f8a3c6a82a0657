"""How closely two exports of one run at different frame rates agree on the locomotion
channels (docs/exporting.md, *Locomotion: driving a walk cycle*).

Runs a built-in scene, exports it to Parquet at two rates as a user would (`crowdmotion
run`, then `crowdmotion export --fps`), and compares the rows of the instants both hold
(every 1/6 s for 24 and 30 fps) where the agent is in the scene in both files: the gait
phase apart (the short way round, in strides), and the share of rows whose gait state or
either foot's contact differs.

    python docs/gait_rates.py [SCENE ...] [--fps 24 30]

(default: rvo_doorway and rvo_town_square, at 24 and 30 fps).
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def crowdmotion(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "crowdmotion", *args], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)


def compare(scene: str, fps: tuple[int, int], tmp: Path) -> dict:
    import pandas as pd

    from crowdmotion.builtin import builtin_scenarios

    path = next(p for p in builtin_scenarios() if p.stem == scene)
    crowdmotion("run", str(path), "-o", str(tmp / scene), "--quiet")
    tables = []
    common = math.gcd(*fps)
    for rate in fps:
        out = tmp / f"{scene}_{rate}.parquet"
        crowdmotion("export", str(tmp / scene), "--to", "parquet", "--fps", str(rate), "-o", str(out))
        t = pd.read_parquet(out, columns=["frame", "agent", "active", "gait_phase", "gait_state", "contact_left",
                                          "contact_right"])
        every = rate // common
        t = t[(t.frame % every == 0) & t.active.astype(bool)]
        tables.append(t.assign(instant=t.frame // every).drop(columns=["frame", "active"]))
    both = tables[0].merge(tables[1], on=["instant", "agent"], suffixes=("_a", "_b"))
    walking = both[both.gait_phase_a.notna() & both.gait_phase_b.notna()]
    apart = np.abs((walking.gait_phase_a - walking.gait_phase_b + 0.5) % 1.0 - 0.5).to_numpy()
    q = np.quantile(apart, [0.5, 0.9, 0.95, 0.99, 1.0])
    return {"scene": scene, "rows": len(apart), "median": q[0], "p90": q[1], "p95": q[2], "p99": q[3], "max": q[4],
            "state": float((both.gait_state_a != both.gait_state_b).mean()),
            "contacts": float(((both.contact_left_a != both.contact_left_b)
                               | (both.contact_right_a != both.contact_right_b)).mean())}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", default=["rvo_doorway", "rvo_town_square"])
    ap.add_argument("--fps", type=int, nargs=2, default=[24, 30])
    args = ap.parse_args(argv)
    print(f"| scene | rows ({args.fps[0]} vs {args.fps[1]} fps) | gait phase apart: median | p90 | p95 | p99 | "
          f"max | gait state differs | a foot's contact differs |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in args.scenes:
            r = compare(scene, tuple(args.fps), Path(tmp))
            print(f"| {r['scene']} | {r['rows']} | {r['median']:.4f} | {r['p90']:.4f} | {r['p95']:.4f} | "
                  f"{r['p99']:.3f} | {r['max']:.2f} | {100 * r['state']:.2f} % | {100 * r['contacts']:.2f} % |",
                  flush=True)


if __name__ == "__main__":
    main()
