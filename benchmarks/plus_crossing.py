"""Two dense streams crossing at right angles: crowdmotion's RVO beside ORCA and JuPedSim.

docs/rvo.md's junction, written as a new user would (``crowdmotion.verify.junction_crossing``):
a 40 x 40 m area with four corner blocks, so two 6 m corridors cross (x 17-23 and y
17-23); 100 people walk east from [0.5, 17.5]-[14, 22.5] to [37, 17]-[40, 23] and 100
north from [17.5, 0.5]-[22.5, 14] to [17, 37]-[23, 40], all from t = 0. crowdmotion runs
it with its defaults. Beside it, on the
same start positions:

- ``orca``: RVO2 (pyrvo) at dt 0.25 s, neighbour distance 10 m, 10 neighbours, time
  horizons 2 s, the group's radius, speeds and max speed; each person aims straight at
  a goal point drawn in its goal area when the way is clear (``query_visibility``),
  else at the junction's middle line; removed on reaching its goal area;
- ``csm``, ``avm``: JuPedSim 1.4's Collision-Free Speed Model and Anticipation Velocity
  Model at their documented defaults (dt 0.01 s, radius 0.2 m; benchmarks/
  empirical_jupedsim.py); a run ends when nobody still inside has moved 5 cm in 60 s.

Printed per run: when the last person is out (or how many are left), how many eastbound
walkers went more than 3 m up the north arm (y > 26) and northbound ones more than 3 m
into the east arm (x > 26), and the frames (every 0.25 s) with two bodies overlapping::

    python benchmarks/plus_crossing.py                       # seeds 1 2 3, about 3 min on 2 cores
    python benchmarks/plus_crossing.py --seeds 1 2 3 4 5 6 7 8 --models
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from crowdmotion.cases import simulate
from crowdmotion.verify import junction_crossing

CARRIED_M = 26.0  # 3 m past the junction's far side (23 m)
ORCA_DT = 0.25
ORCA_MAX_S = 200.0


def measures(positions: np.ndarray, active: np.ndarray, east: np.ndarray, dt: float, left: int | None = None) -> dict:
    """Last out (s; None with someone left), those left (by default those active in the
    last frame), eastbound past y = 26 and northbound past x = 26, from frames ``dt`` apart."""
    y = np.where(active, positions[..., 1], -np.inf)
    x = np.where(active, positions[..., 0], -np.inf)
    left = int(active[-1].sum()) if left is None else left
    return {"last": None if left else float(np.flatnonzero(active.any(axis=1))[-1] * dt), "left": left,
            "east_carried": int((y[:, east].max(axis=0) > CARRIED_M).sum()),
            "north_carried": int((x[:, ~east].max(axis=0) > CARRIED_M).sum())}


def overlap_frames(positions: np.ndarray, active: np.ndarray, radius: float, tol: float = 0.01) -> int:
    """Frames with two active bodies closer than two radii (less ``tol``)."""
    from scipy.spatial import cKDTree

    return sum(bool(cKDTree(p[a]).query_pairs(2 * radius - tol)) for p, a in zip(positions, active) if a.sum() > 1)


def run_orca(scene, groups, start: np.ndarray, seed: int):
    """RVO2 (pyrvo) on the junction from ``start``: (positions, active) every 0.25 s."""
    import pyrvo

    rng = np.random.default_rng(seed)
    g0, g1 = groups
    n0 = g0.count
    radius, vmax = g0.radius, g0.max_speed
    pref = np.r_[np.full(n0, g0.pref_speed), np.full(g1.count, g1.pref_speed)]
    areas = [g0.goal, g1.goal]
    goal_pts = np.vstack([rng.uniform(a.lower, a.upper, size=(g.count, 2)) for a, g in zip(areas, groups)])
    east = np.arange(len(start)) < n0
    sim = pyrvo.RVOSimulator()
    sim.set_time_step(ORCA_DT)
    sim.set_agent_defaults(10.0, 10, 2.0, 2.0, radius, vmax)
    for p in start:
        sim.add_agent((float(p[0]), float(p[1])))
    for o in scene.obstacles:  # the corner blocks, counterclockwise
        (x0, y0), (x1, y1) = o.lower, o.upper
        corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        sim.add_obstacle([(float(x), float(y)) for x, y in corners])
    sim.process_obstacles()
    n = len(start)
    act = np.ones(n, dtype=bool)
    pos = start.astype(float).copy()
    frames, actives = [pos.copy()], [act.copy()]
    for _ in range(int(round(ORCA_MAX_S / ORCA_DT))):
        if not act.any():
            break
        for i in np.flatnonzero(act):
            px, py = pos[i]
            gx, gy = goal_pts[i]
            if sim.query_visibility((px, py), (float(gx), float(gy)), radius):
                tx, ty = gx, gy
            elif east[i]:
                tx, ty = 20.0, min(max(py, 17.5), 22.5)
            else:
                tx, ty = min(max(px, 17.5), 22.5), 20.0
            d = np.hypot(tx - px, ty - py)
            v = pref[i] / d if d > 1e-9 else 0.0
            sim.set_agent_pref_velocity(int(i), (float((tx - px) * v), float((ty - py) * v)))
        sim.do_step()
        for i in np.flatnonzero(act):
            pos[i] = sim.get_agent_position(int(i)).to_tuple()
            a = areas[0] if east[i] else areas[1]
            if np.all(pos[i] >= a.lower) and np.all(pos[i] <= a.upper):  # arrived: parked far off
                act[i] = False
                sim.set_agent_pref_velocity(int(i), (0.0, 0.0))
                sim.set_agent_position(int(i), (5000.0 + 50.0 * i, -5000.0))
        frames.append(pos.copy())  # one who left stays where it left
        actives.append(act.copy())
    return np.stack(frames), np.stack(actives)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--models", nargs="*", default=["orca", "csm", "avm"], help="models beside (orca, csm, avm)")
    args = ap.parse_args(argv)
    rows = []
    for seed in args.seeds:
        setup = junction_crossing("rvo")["junction"]
        out = simulate("rvo", setup, seed)
        tr = out.traj
        east = np.char.startswith(tr.group.astype(str), "east")
        # crowdmotion's last frame still holds the last walker, removed on arriving there
        m = measures(tr.positions, tr.active_mask, east, tr.dt,
                     left=int(round(tr.n_agents * (1.0 - out.summary["arrival_rate"]))))
        m["overlaps"] = f"{out.summary['agent_agent_overlaps']} (continuous audit)"
        rows.append(("crowdmotion rvo (defaults)", seed, m))
        for model in args.models:
            if model == "orca":
                p, a = run_orca(setup.scene, setup.groups, tr.positions[0], seed)
                m = measures(p, a, east, ORCA_DT)
                m["overlaps"] = f"{overlap_frames(p, a, setup.groups[0].radius)} of {len(p)} frames"
                rows.append(("RVO2 ORCA (pyrvo)", seed, m))
                continue
            sys.path.insert(0, str(Path(__file__).parent))
            import empirical_jupedsim as EJ

            jt = EJ.run_jupedsim(model, setup.scene, setup.groups, seed, ORCA_MAX_S)
            je = np.char.startswith(jt.group.astype(str), "east")
            dt = EJ.RECORD_EVERY * EJ.DT
            m = measures(jt.positions, jt.active_mask, je, dt)
            m["overlaps"] = f"{overlap_frames(jt.positions, jt.active_mask, EJ.RADIUS)} of {len(jt.positions)} frames"
            if jt.metadata.get("frozen"):
                m["overlaps"] += "; frozen"
            rows.append((f"JuPedSim {EJ.MODEL_NAMES[model]}", seed, m))
    print("| model | seed | last out, s (left) | east > 3 m up the north arm | north > 3 m into the east arm "
          "| overlaps |")
    print("|---|---|---|---|---|---|")
    for name, seed, m in rows:
        last = f"{m['last']:.1f}" if m["last"] is not None else f"— ({m['left']} left)"
        print(f"| {name} | {seed} | {last} | {m['east_carried']} | {m['north_carried']} | {m['overlaps']} |")


if __name__ == "__main__":
    main()
