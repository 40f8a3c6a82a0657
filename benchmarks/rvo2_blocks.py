"""RVO2's own Blocks example (examples/Blocks.cpp) run in RVO2 itself through pyrvo: the
reference time of `crowdmotion verify --case rvo2_blocks`.

100 agents of radius 2 m (4 x 25, one block per corner at 55-95 m) each walk to their
start mirrored through the origin, past four 30 m square obstacles; RVO2's agent defaults
of the example (neighbour distance 15 m, 10 neighbours, time horizons 5 s, radius 2 m,
speed 2 m/s), time step 0.25 s, preferred velocity the unit vector to the goal (when
farther than 1 m) plus the example's tiny random perturbation. Prints when every agent
was first within 20 m (the example's own end) and within 1 m of its goal.

    pip install ".[bench]"
    python benchmarks/rvo2_blocks.py [--seed 1]
"""

import argparse
import math
import random

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1, help="seed of the example's perturbation (default 1)")
    args = ap.parse_args()
    import pyrvo

    random.seed(args.seed)
    sim = pyrvo.RVOSimulator()
    sim.set_time_step(0.25)
    sim.set_agent_defaults(15.0, 10, 5.0, 5.0, 2.0, 2.0)
    goals = []
    for i in range(5):
        for j in range(5):
            for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1)):
                p = (sx * (55 + i * 10.0), sy * (55 + j * 10.0))
                sim.add_agent(p)
                goals.append((-p[0], -p[1]))
    for poly in ([(-10, 40), (-40, 40), (-40, 10), (-10, 10)], [(10, 40), (10, 10), (40, 10), (40, 40)],
                 [(10, -40), (40, -40), (40, -10), (10, -10)], [(-10, -40), (-10, -10), (-40, -10), (-40, -40)]):
        sim.add_obstacle([tuple(map(float, v)) for v in poly])
    sim.process_obstacles()
    goals = np.array(goals)
    n = len(goals)
    t20 = np.full(n, np.nan)
    t1 = np.full(n, np.nan)
    for step in range(20000):
        pos = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
        d = np.linalg.norm(goals - pos, axis=1)
        t20[np.isnan(t20) & (d < 20)] = step * 0.25
        t1[np.isnan(t1) & (d < 1)] = step * 0.25
        if not np.isnan(t1).any():
            break
        for i in range(n):
            g = goals[i] - pos[i]
            if g @ g > 1:
                g = g / np.linalg.norm(g)
            angle, dist = random.random() * 2 * math.pi, random.random() * 0.0001
            sim.set_agent_pref_velocity(i, (float(g[0] + dist * math.cos(angle)), float(g[1] + dist * math.sin(angle))))
        sim.do_step()
    print(f"RVO2 Blocks (seed {args.seed}): within 20 m of the goal: mean {np.nanmean(t20):.1f} s, last "
          f"{np.nanmax(t20):.1f} s; within 1 m: mean {np.nanmean(t1):.1f} s, last {np.nanmax(t1):.1f} s; "
          f"{int((~np.isnan(t1)).sum())} of {n} reached")


if __name__ == "__main__":
    main()
