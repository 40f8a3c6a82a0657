"""Do the RVO built-ins still walk the same paths? A check for changes meant to be pure
speed-ups (kernels, threads, bookkeeping): run a few built-in RVO scenes for a fixed
number of steps, save every frame's positions, and compare with a saved run, bit for bit.

    python benchmarks/rvo_same_paths.py --save /tmp/before      # on the old code
    python benchmarks/rvo_same_paths.py --compare /tmp/before   # on the new code

Prints, per scene, a digest of the positions and, with ``--compare``, whether the frames
are identical; where they are not, the first differing step, the largest difference and
the arrivals, overlaps and safety stops of both runs. Scenes: the doorway (120 people,
two ways), the stand evacuation (2000 people, its first ``--stand-steps`` steps) and two
streets (``rvo_street_O``, ``rvo_blocked_street``) and the stand with its exits
(``rvo_stand_exits``, its first 300 steps).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.rvo.simulation import build_simulator
from crowdmotion.scenario import load_scenario

SCENES = {"rvo_doorway": None, "rvo_street_O": None, "rvo_blocked_street": None, "rvo_stand_evacuation": 300,
          "rvo_stand_exits": 300}


def run(name: str, steps: int | None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(positions per frame, arrival times, stats) of ``name`` over ``steps`` steps (None: to the end)."""
    sc = load_scenario({p.stem: p for p in builtin_scenarios()}[name])
    sim = build_simulator(sc.scene, sc.groups, sc.params, np.random.default_rng(sc.spec.seed))
    last = sc.params.max_steps if steps is None else min(steps, sc.params.max_steps)
    frames = [sim.positions.copy()]
    while sim.steps < last and (sim.active & ~sim.arrived).any():
        sim.step()
        frames.append(sim.positions.copy())
    return np.array(frames), sim.arrival_time.copy(), dict(sim.stats)


def digest(frames: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(frames).tobytes()).hexdigest()[:16]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--save", type=Path, help="folder to save this run's frames in")
    ap.add_argument("--compare", type=Path, help="folder of a saved run to compare with")
    ap.add_argument("--stand-steps", type=int, default=SCENES["rvo_stand_evacuation"])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    args = ap.parse_args(argv)
    same = True
    for name in args.scenes:
        steps = args.stand_steps if name == "rvo_stand_evacuation" else SCENES[name]
        frames, arrival, stats = run(name, steps)
        line = f"{name}: {len(frames) - 1} steps, digest {digest(frames)}, arrived {int(np.isfinite(arrival).sum())}"
        if args.save:
            args.save.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(args.save / f"{name}.npz", frames=frames, arrival=arrival)
            (args.save / f"{name}.json").write_text(json.dumps(stats))
        if args.compare:
            old = np.load(args.compare / f"{name}.npz")
            old_stats = json.loads((args.compare / f"{name}.json").read_text())
            if old["frames"].shape == frames.shape and np.array_equal(old["frames"], frames) \
                    and np.array_equal(old["arrival"], arrival, equal_nan=True):
                line += ": identical bit for bit"
            else:
                same = False
                n = min(len(old["frames"]), len(frames))
                diff = np.abs(old["frames"][:n] - frames[:n]).max(axis=(1, 2))
                first = int(np.argmax(diff > 0)) if (diff > 0).any() else n
                line += (f": DIFFERENT from step {first} (largest difference {diff.max():.3g} m; "
                         f"steps {len(old['frames']) - 1} -> {len(frames) - 1}; "
                         f"stats {old_stats} -> {stats})")
        print(line, flush=True)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
