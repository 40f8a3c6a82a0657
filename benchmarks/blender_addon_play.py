"""How a frame change in Blender grows with the add-on's characters.

A frame change evaluates every character's root path, NLA strips and skinned body, so its
cost should grow with the characters, not with their square (2000 agents is a built-in
scene). This imports runs of N agents walking east in rows (a tenth stand, a seventh leave
halfway) with the add-on into the real ``bpy`` module and plays them, printing the median
and longest ``scene.frame_set`` and the median per character, with its ratio to the
smallest run's (about 1 when linear; quadratic would be N / N_smallest)::

    python benchmarks/blender_addon_play.py --python /path/to/bpyenv/bin/python --sizes 50 500 2000

``--frames`` sets the runs' length (96 by default; ``--sizes 2000 --frames 500`` is issue
31's 2000 agents x 500 frames). A second table gives each run's import stages (the
add-on's own times) and the import operator's total, as File > Import runs it.

``--python`` is a Python with the ``bpy`` package (default: ``CROWDMOTION_BLENDER_PYTHON``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from crowdmotion import Trajectories
from crowdmotion.blender import write_addon

CHECK = Path(__file__).resolve().parents[1] / "tests" / "io" / "blender_addon_check.py"


def run_addon_check(blender_python: str, usd: Path, folder: Path, *args: str, timeout: float = 1800) -> dict:
    """Install the add-on into ``folder``, import ``usd`` with it in the real ``bpy``
    (tests/io/blender_addon_check.py with ``args``) and return the check's JSON result."""
    (folder / "user").mkdir(parents=True, exist_ok=True)
    addon = write_addon(folder)
    done = subprocess.run([blender_python, str(CHECK), str(addon), str(usd), str(folder), *args],
                          capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "BLENDER_USER_RESOURCES": str(folder / "user")})
    line = next((x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON ")), None)
    if line is None:
        raise SystemExit(f"the bpy check printed no result:\n{done.stderr[-3000:]}")
    return json.loads(line.split(" ", 1)[1])


def play(blender_python: str, folder: Path, n: int, frames: int = 96, fps: float = 24.0) -> dict:
    """Import a run of ``n`` agents with the add-on and play it: the check's stage times and
    frame-change seconds (``play_s``: median and max)."""
    rng = np.random.default_rng(n)
    t = np.arange(frames) / fps
    speed = rng.uniform(0.6, 1.8, n) * (rng.random(n) > 0.1)  # a tenth stand
    start = np.stack([rng.uniform(0, 5, n), np.arange(n) * 0.8], axis=1)
    pos = start[None] + speed[None, :, None] * t[:, None, None] * np.array([1.0, 0.0])
    active = np.ones((frames, n), bool)
    active[frames // 2:, ::7] = False  # a seventh leave halfway (hidden from then on)
    tr = Trajectories(pos, 1 / fps, radius=[0.25] * n, group=[("a", "b", "c")[i % 3] for i in range(n)], active=active)
    folder = folder / f"n{n}"
    folder.mkdir(parents=True)
    got = run_addon_check(blender_python, tr.save(folder / "run.usdc"), folder, "--play", f"1:{frames}")
    if got["result"] != ["FINISHED"] or got["agents"] != n:
        raise SystemExit(f"the import did not finish with {n} agents: {got}")
    return got


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--python", default=os.environ.get("CROWDMOTION_BLENDER_PYTHON"),
                    help="a Python with bpy (default: $CROWDMOTION_BLENDER_PYTHON)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[50, 500])
    ap.add_argument("--frames", type=int, default=96, help="frames of each run (at 24 fps)")
    args = ap.parse_args(argv)
    if not args.python:
        ap.error("name a Python with bpy: --python or CROWDMOTION_BLENDER_PYTHON")
    if any(n < 1 for n in args.sizes) or args.frames < 3:
        ap.error("--sizes must be positive and --frames at least 3")
    print("| characters | frame change, median | longest | per character | per character / smallest run's |")
    print("|---|---|---|---|---|")
    base = None
    stages = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sorted(args.sizes):
            got = play(args.python, Path(tmp), n, args.frames)
            s = got["play_s"]
            per = s["median"] / n
            base = per if base is None else base
            print(f"| {n:,} | {s['median']:.3f} s | {s['max']:.3f} s | {per * 1e3:.3f} ms | {per / base:.2f} |",
                  flush=True)
            stages.append((n, got))
    names = list(stages[0][1]["times"])
    print(f"\n| characters x frames | {' | '.join(names)} | the stages | the import operator |")
    print("|---|" + "---|" * (len(names) + 2))
    for n, got in stages:
        times = got["times"]
        print(f"| {n:,} x {args.frames} | " + " | ".join(f"{times[k]:.2f} s" for k in names)
              + f" | {sum(times.values()):.1f} s | {got['import_s']:.1f} s |")


if __name__ == "__main__":
    main()
