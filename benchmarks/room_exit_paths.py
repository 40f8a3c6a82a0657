"""How a crowd waits before a door: crowdmotion's RVO against JuPedSim's pedestrian models.

docs/rvo.md's room (80 people leaving a 14 x 10 m room by a 1 m door at x = 10-10.3 m,
spawned in [0.5, 9.5]², bound for [12, 3]-[13.5, 7]), run with crowdmotion's defaults and
with JuPedSim 1.4's Collision-Free Speed Model and Anticipation Velocity Model at their
documented defaults (time step 0.01 s; the same spawn region and count, drawn with the
seed, radius 0.25 m and speed 1.3 m/s). For every agent inside the room (x < 9.9 m) between two frames 0.25 s apart,
its velocity is split along the straight line to the door's centre (10.15, 5): the
distance walked away from the door and the distance walked sideways, each over the
distance walked towards it. People waiting in an arc round a door walk almost only
towards it; the mean path over the straight line and when the last one is out are
printed beside them::

    python benchmarks/room_exit_paths.py               # seeds 1 2, about 2 min on 2 cores
    python benchmarks/room_exit_paths.py --seeds 1 2 3 4 --models csm avm
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from crowdmotion.scenario import parse_scenario, run_scenario

ROOM = """
name = "room_exit"
method = "rvo"
seed = {seed}

[scene]
bounds = [[0.0, 0.0], [14.0, 10.0]]
obstacles = [
  {{ shape = "box", lower = [10.0, 0.0], upper = [10.3, 4.5] }},
  {{ shape = "box", lower = [10.0, 5.5], upper = [10.3, 10.0] }},
]

[[groups]]
name = "occupants"
count = 80
spawn = {{ shape = "rect", lower = [0.5, 0.5], upper = [9.5, 9.5] }}
goal  = {{ shape = "rect", lower = [12.0, 3.0], upper = [13.5, 7.0] }}
"""
DOOR = np.array([10.15, 5.0])
INSIDE_X = 9.9  # the room, short of the door's mouth


def measures(positions: np.ndarray, active: np.ndarray, dt: float) -> dict:
    """Away and sideways over towards the door (inside the room), mean path over the
    straight line from start to last position, and the time the last agent was active."""
    towards = away = side = 0.0
    for k in range(len(positions) - 1):
        m = active[k] & active[k + 1] & (positions[k, :, 0] < INSIDE_X)
        u = DOOR - positions[k, m]
        u /= np.linalg.norm(u, axis=1)[:, None]
        step = positions[k + 1, m] - positions[k, m]
        along = (step * u).sum(axis=1)
        towards += np.clip(along, 0.0, None).sum()
        away += np.clip(-along, 0.0, None).sum()
        side += np.abs(step[:, 0] * u[:, 1] - step[:, 1] * u[:, 0]).sum()
    both = active[1:] & active[:-1]
    walked = (np.linalg.norm(np.diff(positions, axis=0), axis=2) * both).sum(axis=0)
    last = np.array([positions[np.flatnonzero(active[:, i])[-1], i] for i in range(positions.shape[1])])
    straight = np.linalg.norm(last - positions[0], axis=1)
    return {"away": away / towards, "sideways": side / towards,
            "path": float(np.mean(walked / np.maximum(straight, 1e-9))),
            "out": float(np.flatnonzero(active.any(axis=1))[-1] * dt)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--models", nargs="*", default=["csm", "avm"], help="JuPedSim models beside (csm, avm, sfm)")
    args = ap.parse_args(argv)
    rows = []
    for seed in args.seeds:
        sc = parse_scenario(ROOM.format(seed=seed))
        tr = run_scenario(sc, progress=False).trajectories
        rows.append(("crowdmotion rvo (defaults)", seed, measures(tr.positions, tr.active_mask, tr.dt)))
        if args.models:
            sys.path.insert(0, str(Path(__file__).parent))
            import empirical_jupedsim as EJ

            EJ.RADIUS = sc.groups[0].radius
            for model in args.models:
                jt = EJ.run_jupedsim(model, sc.scene, sc.groups, seed, 300.0)
                rows.append((f"JuPedSim {EJ.MODEL_NAMES[model]}", seed,
                             measures(jt.positions, jt.active_mask, EJ.RECORD_EVERY * EJ.DT)))
    print("| model | seed | away / towards the door | sideways / towards | path / straight line | last out, s |")
    print("|---|---|---|---|---|---|")
    for name, seed, m in rows:
        print(f"| {name} | {seed} | {m['away']:.2f} | {m['sideways']:.2f} | {m['path']:.2f} | {m['out']:.1f} |")


if __name__ == "__main__":
    main()
