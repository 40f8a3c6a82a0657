"""Where a resampled export still turns sharply: built-in RVO scenes run at their own
settings, resampled at 24 and 60 fps along the B-spline as `crowdmotion export --fps`
does, the steps it cannot keep falling back (a) to the spline through the run's frames,
then to straight moves (what an export does), or (b) straight away to straight moves.
For each: the steps on each fallback, and the frames of moving walkers (> 0.3 m/s)
accelerating faster than 10 m/s², with the largest (docs/exporting.md, "Root motion").

    python benchmarks/export_corners.py                 # about 30 s
    python benchmarks/export_corners.py rvo_doorway --fps 60
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.scene import scene_of
from crowdmotion.scenario import run_scenario
from crowdmotion.smoothing import keep_clean
from crowdmotion.trajectories import Trajectories, resample

SCENES = ["rvo_doorway", "rvo_town_square", "rvo_station_concourse"]
SHARP = 10.0  # m/s²
MOVING = 0.3  # m/s


def _sharp(out: Trajectories) -> tuple[int, float]:
    """Frames of moving walkers accelerating faster than SHARP, and the largest (m/s²)."""
    p, act, h = out.positions, out.active_mask, out.dt
    v = (p[2:] - p[:-2]) / (2 * h)
    acc = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=-1) / (h * h)
    a = acc[act[2:] & act[1:-1] & act[:-2] & (np.linalg.norm(v, axis=-1) > MOVING)]
    return int((a > SHARP).sum()), float(a.max(initial=0.0))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", default=SCENES, help=f"built-in scenes (default {' '.join(SCENES)})")
    ap.add_argument("--fps", type=float, nargs="+", default=[24.0, 60.0])
    args = ap.parse_args(argv)
    paths = {p.stem: p for p in builtin_scenarios()}
    print("| scene | fps | through the frames, then straight: steps through / straight, frames > 10 m/s², max "
          "| straight at once: steps straight, frames > 10 m/s², max |")
    print("|---|---|---|---|")
    for name in args.scenes:
        tr = run_scenario(paths[name], progress=False).trajectories
        scene, limit = scene_of(tr), np.zeros(tr.n_agents)
        for fps in args.fps:
            smooth, linear, through = (resample(tr, fps, k) for k in ("b-spline", "linear", "catmull-rom"))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                graded = keep_clean(smooth, linear, tr, scene, limit, "b-spline", through=through)
                at_once = keep_clean(smooth, linear, tr, scene, limit, "b-spline")
            g, s = graded.metadata["resampled"], at_once.metadata["resampled"]
            (gn, gmax), (sn, smax) = _sharp(graded), _sharp(at_once)
            print(f"| {name} | {fps:g} | {g['through_segments']} / {g['straight_segments']}, {gn}, {gmax:.1f} | "
                  f"{s['straight_segments']}, {sn}, {smax:.1f} |", flush=True)


if __name__ == "__main__":
    main()
