"""One person waiting 60 s in a corridor, walkers coming by: how often a walker is held
behind the one waiting for the whole wait (docs/rvo.md, "Passing those who stand").

A corridor 20 m long and 1.4, 1.8, 2.2 or 2.6 m wide (the scene's bounds are its walls);
one person of radius 0.25 m waits at its middle (x 10 m), on the centre line or 0.3 m off
it (a `wait` stage of 60 s, then leaves); one walker from the west end, two from the west
end, or one from each end, each bound for the far end (arrivals leave); seeds 0 and 1.
A walker still in the corridor at 59 s was held for the wait (the free walk takes about
15 s). Printed: the runs held, the continuous-time audit, and how far the one waiting
was pushed from its place at most.

    python benchmarks/waiting_in_corridor.py                       # 48 runs, about 20 s on 2 cores
    python benchmarks/waiting_in_corridor.py --no-pass-standing    # the same without the rule
"""

from __future__ import annotations

import argparse
import itertools
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.metrics import collision_audit
from crowdmotion.stages import Leave, Wait

WIDTHS = (1.4, 1.8, 2.2, 2.6)
OFFSETS = (0.0, 0.3)
WALKERS = ("one", "two", "each way")
WAIT_S = 60.0


def _run(job: tuple[float, float, str, int, bool]) -> tuple[tuple, bool, int, float]:
    """(the run, whether a walker was held for the wait, audit events, the push in m)."""
    width, off, walkers, seed, pass_standing = job
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, width])), rng=np.random.default_rng(seed),
                        pass_standing=pass_standing)
    mid = width / 2
    place = np.array([10.0, mid + off])
    waiting = sim.add_agents(place[None], place[None])
    sim.set_route(waiting, [Wait(WAIT_S), Leave(cm.groups.Rect([19.0, 0.1], [19.9, width - 0.1]))])
    starts, goals = [[1.0, mid]], [[19.5, mid]]
    if walkers == "two":  # abreast where the corridor holds two, else one behind the other
        starts.append([1.0, mid + 0.6] if width > 1.5 else [0.4, mid])
        goals.append([19.5, mid])
    elif walkers == "each way":
        starts.append([19.0, mid])
        goals.append([0.5, mid])
    ids = sim.add_agents(np.array(starts), np.array(goals))
    frames, present = [sim.positions.copy()], [sim.present.copy()]
    while sim.present[ids].any() and sim.time < WAIT_S - 1.0:
        sim.step()
        frames.append(sim.positions.copy())
        present.append(sim.present.copy())
    traj = cm.Trajectories(np.array(frames), sim.dt, radius=sim.params["radius"], active=np.array(present))
    audit = collision_audit(traj, sim.scene)
    pushed = float(np.linalg.norm(np.array(frames)[:, waiting[0]] - place, axis=1).max())
    return job[:4], bool(sim.present[ids].any()), audit.agent_agent + audit.agent_obstacle, pushed


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-pass-standing", action="store_true", help="pass_standing = False (eq. (3)'s reciprocal rule)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1, help="runs side by side (default: one per core)")
    args = ap.parse_args(argv)
    jobs = [(*run, not args.no_pass_standing) for run in itertools.product(WIDTHS, OFFSETS, WALKERS, args.seeds)]
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        rows = list(pool.map(_run, jobs))
    held = [r[0] for r in rows if r[1]]
    print(f"{len(rows)} runs (pass_standing = {not args.no_pass_standing}): a walker held for the whole "
          f"{WAIT_S:g} s wait in {len(held)}; audit events {sum(r[2] for r in rows)}; the one waiting pushed "
          f"{max(r[3] for r in rows):.2f} m from its place at most")
    for width, off, walkers, seed in held:
        print(f"  held: {width:g} m wide, waiting {off:g} m off the middle, {walkers}, seed {seed}")


if __name__ == "__main__":
    main()
