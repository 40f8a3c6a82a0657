"""RVO2's own Circle and Roadmap examples (snape/RVO2, examples/Circle.cc and
examples/Roadmap.cc) run in RVO2 itself through pyrvo: the reference numbers of
`crowdmotion verify --case rvo2_circle` and `--case rvo2_roadmap`.

Circle: 250 agents on a circle of radius 200 m, each bound for its antipode; agent
defaults (neighbour distance 15 m, 10 neighbours, time horizons 10 s, radius 1.5 m,
max speed 2 m/s), time step 0.25 s; preferred velocity the vector to the goal, cut to
unit length (1 m/s) when longer than 1 m; no perturbation. The example stops once every
agent is within its radius of its goal at the same time (arrived agents stay).

Roadmap: the Blocks scene (four 30 m squares, 4 x 25 agents of radius 2 m, 2 m/s, time
horizons 5 s) where each corner's 25 agents go to one roadmap vertex at the opposite
corner, (+-75, +-75), along a visibility roadmap of 20 vertices (Dijkstra to each goal);
preferred velocity the unit vector towards the visible vertex that is nearest the goal
along the roadmap, plus the example's tiny random perturbation (seeded here). It stops
once every agent is within 20 m of its goal vertex.

Prints when the example's own stopping test first held, how many agents ever met it,
the closest two agents came (ORCA lets bodies overlap slightly) and the wall time.

    pip install ".[bench]"
    python benchmarks/rvo2_examples.py circle
    python benchmarks/rvo2_examples.py roadmap --seed 1
"""

import argparse
import math
import random
import time

import numpy as np

BLOCKS = ([(-10, 40), (-40, 40), (-40, 10), (-10, 10)], [(10, 40), (10, 10), (40, 10), (40, 40)],
          [(10, -40), (40, -40), (40, -10), (10, -10)], [(-10, -40), (-10, -10), (-40, -10), (-40, -40)])
ROADMAP = [(-75, -75), (75, -75), (-75, 75), (75, 75)] + [(x, y) for x in (-42, -8, 8, 42) for y in (-42, -8, 8, 42)]


def _min_gap(pos: np.ndarray, radius: float) -> float:
    d = np.linalg.norm(pos[:, None] - pos[None], axis=2)
    np.fill_diagonal(d, np.inf)
    return float(d.min() - 2 * radius)


def circle(max_steps: int) -> None:
    import pyrvo

    sim = pyrvo.RVOSimulator()
    sim.set_time_step(0.25)
    sim.set_agent_defaults(15.0, 10, 10.0, 10.0, 1.5, 2.0)
    for i in range(250):
        a = i * 2 * math.pi * 0.004
        sim.add_agent((200.0 * math.cos(a), 200.0 * math.sin(a)))
    n = sim.get_num_agents()
    goals = -np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
    first = np.full(n, np.nan)
    gap, t0, done, stepping = np.inf, time.perf_counter(), None, 0.0
    for step in range(max_steps):
        pos = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
        gap = min(gap, _min_gap(pos, 1.5))
        within = np.linalg.norm(goals - pos, axis=1) <= 1.5
        first[np.isnan(first) & within] = step * 0.25
        if step > 0 and within.all():  # the example's reachedGoal, tested after each doStep
            done = step * 0.25
            break
        for i in range(n):
            g = goals[i] - pos[i]
            if g @ g > 1.0:
                g = g / np.linalg.norm(g)
            sim.set_agent_pref_velocity(i, (float(g[0]), float(g[1])))
        t1 = time.perf_counter()
        sim.do_step()
        stepping += time.perf_counter() - t1
    wall = time.perf_counter() - t0
    print(f"RVO2 Circle: all {n} within 1.5 m of their goals at once at "
          f"{'never (in %d steps)' % max_steps if done is None else f'{done:.2f} s'}; "
          f"{int(np.isfinite(first).sum())} ever within 1.5 m, the last first at {np.nanmax(first):.2f} s; "
          f"closest approach {gap:+.3f} m (negative: overlap); wall {wall:.1f} s, do_step alone {stepping:.2f} s")


def roadmap(seed: int, max_steps: int) -> None:
    import pyrvo

    random.seed(seed)
    sim = pyrvo.RVOSimulator()
    sim.set_time_step(0.25)
    for poly in BLOCKS:
        sim.add_obstacle([tuple(map(float, v)) for v in poly])
    sim.process_obstacles()
    verts = np.array(ROADMAP, dtype=float)
    sim.set_agent_defaults(15.0, 10, 5.0, 5.0, 2.0, 2.0)
    goal_of = []
    for i in range(5):
        for j in range(5):
            for (sx, sy), goal in (((1, 1), 0), ((-1, 1), 1), ((1, -1), 2), ((-1, -1), 3)):
                sim.add_agent((sx * (55.0 + i * 10.0), sy * (55.0 + j * 10.0)))
                goal_of.append(goal)
    goal_of = np.array(goal_of)
    n = len(goal_of)
    # the example's buildRoadmap: edges between mutually visible vertices, Dijkstra to each goal
    m = len(verts)
    w = np.full((m, m), np.inf)
    for a in range(m):
        for b in range(m):
            if sim.query_visibility(tuple(verts[a]), tuple(verts[b]), 2.0):
                w[a, b] = np.linalg.norm(verts[a] - verts[b])
    dist = np.full((m, 4), np.inf)
    for gi in range(4):
        dist[gi, gi] = 0.0
        todo = set(range(m))
        while todo:
            u = min(todo, key=lambda k: dist[k, gi])
            todo.discard(u)
            for v in range(m):
                dist[v, gi] = min(dist[v, gi], dist[u, gi] + w[u, v])
    first = np.full(n, np.nan)
    gap, t0, done, stepping = np.inf, time.perf_counter(), None, 0.0
    for step in range(max_steps):
        pos = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
        gap = min(gap, _min_gap(pos, 2.0))
        within = np.linalg.norm(verts[goal_of] - pos, axis=1) <= 20.0
        first[np.isnan(first) & within] = step * 0.25
        if step > 0 and within.all():
            done = step * 0.25
            break
        for i in range(n):
            best, vmin = np.inf, None
            for j in range(m):
                c = np.linalg.norm(verts[j] - pos[i]) + dist[j, goal_of[i]]
                if c < best and sim.query_visibility(tuple(pos[i]), tuple(verts[j]), 2.0):
                    best, vmin = c, j
            if vmin is None:
                pv = np.zeros(2)
            elif np.all(verts[vmin] == pos[i]):
                pv = np.zeros(2) if vmin == goal_of[i] else (verts[goal_of[i]] - pos[i]) / np.linalg.norm(
                    verts[goal_of[i]] - pos[i])
            else:
                pv = (verts[vmin] - pos[i]) / np.linalg.norm(verts[vmin] - pos[i])
            angle, d = random.random() * 2 * math.pi, random.random() * 0.0001
            sim.set_agent_pref_velocity(i, (float(pv[0] + d * math.cos(angle)), float(pv[1] + d * math.sin(angle))))
        t1 = time.perf_counter()
        sim.do_step()
        stepping += time.perf_counter() - t1
    wall = time.perf_counter() - t0
    print(f"RVO2 Roadmap (seed {seed}): all {n} within 20 m of their goal vertex at once at "
          f"{'never (in %d steps)' % max_steps if done is None else f'{done:.2f} s'}; "
          f"{int(np.isfinite(first).sum())} ever within 20 m; closest approach {gap:+.3f} m; wall {wall:.1f} s, do_step alone {stepping:.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("example", choices=("circle", "roadmap"))
    ap.add_argument("--seed", type=int, default=1, help="seed of the Roadmap example's perturbation (default 1)")
    ap.add_argument("--max-steps", type=int, default=20000)
    args = ap.parse_args()
    if args.example == "circle":
        circle(args.max_steps)
    else:
        roadmap(args.seed, args.max_steps)


if __name__ == "__main__":
    main()
