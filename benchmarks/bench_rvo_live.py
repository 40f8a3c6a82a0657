"""What the RVO live API costs a game that gives its crowd new goals as it plays.

1. A wave of new goals: in a 50 × 40 m plaza with five buildings (field cell 0.3 m), 300
   walkers; 15 of them get a goal point each (15 new guidance fields) with ``set_goals``.
   Beside it, in the same run, the same 15 fields solved one by one with the move graph
   built for each (``exact_values`` without ``graph``), the way they were solved before
   ``distance_fields`` built it once per call.
2. Wanderers: 72 walkers in a 60 × 60 m scene with two buildings, ten of them given a new
   goal point every 2 s, for 100 simulated seconds at the default step: wall time, and the
   guidance fields held at the end (count and MB).
3. A cart pushed every frame: 250 walkers bound for four goal regions in a 40 × 30 m
   square (a fountain, four kiosks) at 60 steps a second; a 0.6 m cart moved 2 cm with
   ``move_obstacle`` before each of 300 steps: the cost of a move (median, max).
4. The stand evacuation stepped at a game's 60 frames a second: 2000 walkers bound for the
   concourse (one goal region) through three 2 m exits, 600 frames (five congestion
   re-solves, every 2 s): each frame's time (median, the frames that start a re-solve,
   the worst), beside the same run with each re-solve done whole in its first frame
   (``REPLAN_SPREAD_S`` = 0), as a single field's search was before it was cut into
   slices spread over the frames of a quarter second.
5. Wanderers at a game's 30 frames a second: 200 walkers in a 30 x 30 m plaza (a
   fountain, a stall), each given a goal point of its own, and a new one when it arrives
   (``set_goals(..., leave=False)``), 40 s; each frame's time over the last 30 s (median,
   p95, p99, the worst), beside the same run with the re-solves squeezed into the first
   quarter second of their period whatever they hold (``REPLAN_CELLS_PER_STEP`` = inf);
   and how the walkers move, from their positions frame by frame (those moving faster
   than 0.3 m/s, central differences): acceleration p99, the share of frames over
   5 m/s², turn rate p99 and mean speed.
6. A point chased: 100 walkers in the plaza of 1. (three buildings) given a new goal
   point, one for all, at every one of 120 frames at 60 frames a second (a game's moving
   rally point given as points, not as a MovingTarget): the cost of ``set_goals``
   (median, max), a new guidance field each time.

    python benchmarks/bench_rvo_live.py
"""

from __future__ import annotations

import time
import warnings

import numpy as np

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.mdp.solvers import exact_values

WAVES = 5


def _clear(p, boxes) -> bool:
    """Whether point ``p`` is more than 1 m from every box ((lower, upper) corners)."""
    return not any(np.all(p > np.array(lo) - 1) and np.all(p < np.array(hi) + 1) for lo, hi in boxes)


def _free_points(rng, k, lo, hi, boxes):
    pts = []
    while len(pts) < k:
        p = rng.uniform(lo, hi, 2)
        if _clear(p, boxes):
            pts.append(p)
    return np.array(pts)


def wave_of_goals() -> None:
    boxes = [([8, 8], [16, 14]), ([22, 26], [30, 34]), ([34, 6], [42, 12]), ([5, 26], [12, 33]), ([38, 22], [45, 30])]
    scene = cm.Scene(bounds=([0, 0], [50, 40]), obstacles=[cm.Box(a, b) for a, b in boxes])
    rng = np.random.default_rng(0)
    sim = rvo.Simulator(scene, field_cell=0.3, rng=np.random.default_rng(0), remove_on_arrival=False)
    lattice = np.stack(np.meshgrid(np.arange(1.0, 49, 1.2), np.arange(1.0, 39, 1.2)), -1).reshape(-1, 2)
    lattice = lattice[[_clear(p, boxes) for p in lattice]]
    starts = lattice[rng.choice(len(lattice), 300, replace=False)]
    ids = sim.add_agents(starts, cm.Rect([45, 33], [49, 39]).center, goal_region=cm.Rect([45, 33], [49, 39]))
    sim.step()
    ours, one_by_one = [], []
    for _ in range(WAVES):
        who = rng.choice(ids, 15, replace=False)
        goals = _free_points(rng, 15, 1, [49, 39], boxes)
        t = time.perf_counter()
        sim.set_goals(who, goals)
        ours.append(time.perf_counter() - t)
        grid = sim._fields.blocked.astype(np.uint8)
        cells = sim._fields.cells(goals)
        t = time.perf_counter()
        for c in cells:
            exact_values(grid, [tuple(c)], corner_cutting=False)
        one_by_one.append(time.perf_counter() - t)
        sim.step()
    print(f"wave of 15 new goal points, 300 walkers, 50 x 40 m plaza (cell 0.3 m): set_goals "
          f"{np.median(ours) * 1e3:.0f} ms median of {WAVES}; the 15 fields one by one, graph built for each: "
          f"{np.median(one_by_one) * 1e3:.0f} ms ({np.median(one_by_one) / np.median(ours):.1f}x)")


def wanderers() -> None:
    boxes = [([20, 20], [25, 40]), ([35, 10], [40, 30])]
    scene = cm.Scene(bounds=([0, 0], [60, 60]), obstacles=[cm.Box(a, b) for a, b in boxes])
    rng = np.random.default_rng(0)
    sim = rvo.Simulator(scene, rng=np.random.default_rng(0), remove_on_arrival=False)
    start = np.stack(np.meshgrid(np.arange(3, 57, 3.0), [2.0, 5.0, 55.0, 58.0]), -1).reshape(-1, 2)
    ids = np.concatenate([sim.add_agents(start[k:k + 12], _free_points(rng, 12, 2, 58, boxes))
                          for k in range(0, len(start), 12)])
    sim.step()
    t = time.perf_counter()
    for step in range(1, 401):
        if step % 8 == 0:
            sim.set_goals(rng.choice(ids, 10, replace=False), _free_points(rng, 10, 2, 58, boxes))
        sim.step()
    wall = time.perf_counter() - t
    held = sim._exact.nbytes + (0 if sim._fields.dist is sim._exact else sim._fields.dist.nbytes)
    print(f"72 wanderers, 10 new goal points every 2 s, 60 x 60 m with two buildings: 100 s simulated in "
          f"{wall:.1f} s; {len(sim._exact)} guidance fields held ({held / 1e6:.0f} MB)")


def pushed_cart() -> None:
    scene = cm.Scene(bounds=([0, 0], [40, 30]), obstacles=[
        cm.Circle([20, 15], 2), cm.Box([5, 5], [9, 9]), cm.Box([31, 5], [35, 9]), cm.Box([5, 21], [9, 25]),
        cm.Box([31, 21], [35, 25])])
    sim = rvo.Simulator(scene, time_step=1 / 60, rng=np.random.default_rng(1))
    regions = [cm.Rect([0.5, 12], [2, 18]), cm.Rect([38, 12], [39.5, 18]), cm.Rect([15, 0.5], [25, 2]),
               cm.Rect([15, 28], [25, 29.5])]
    lattice = np.stack(np.meshgrid(np.arange(11.0, 29.5, 1.0), np.arange(3.0, 27.5, 1.0)), -1).reshape(-1, 2)
    lattice = lattice[np.linalg.norm(lattice - [20, 15], axis=1) > 3][:250]
    for k, region in enumerate(regions):
        sim.add_agents(lattice[k::4], region.center, goal_region=region, arrive_anywhere=True)
    for _ in range(30):
        sim.step()
    cart = sim.add_obstacle(cm.Circle([20, 29.2], 0.6))  # along the north edge, clear of the walkers
    moves = []
    for _ in range(300):
        t = time.perf_counter()
        cart = sim.move_obstacle(cart, (-0.02, 0.0))
        moves.append(time.perf_counter() - t)
        sim.step()
    print(f"a cart moved before each step (250 walkers, four goal regions, 40 x 30 m, 60 steps/s): move_obstacle "
          f"{np.median(moves) * 1e3:.0f} ms median, {max(moves) * 1e3:.0f} ms at most")


def stand_at_60_fps() -> None:
    walls = [([0, 13], [9, 14]), ([11, 13], [29, 14]), ([31, 13], [49, 14]), ([51, 13], [60, 14])]
    scene = cm.Scene(bounds=([0, 0], [60, 40]), obstacles=[cm.Box(a, b) for a, b in walls])
    rng = np.random.default_rng(0)
    places = np.stack(np.meshgrid(np.arange(0.8, 59.5, 0.62), np.arange(14.8, 39.5, 0.62)), -1).reshape(-1, 2)
    places = places[rng.choice(len(places), 2000, replace=False)]
    speeds = rng.uniform(0.9, 1.5, 2000)
    concourse = cm.Rect([0.5, 0.5], [59.5, 5.0])
    rows = {}
    for label, spread_s in (("sliced over 0.25 s", rvo.simulator.REPLAN_SPREAD_S), ("whole in one frame", 0.0)):
        rvo.simulator.REPLAN_SPREAD_S, kept = spread_s, rvo.simulator.REPLAN_SPREAD_S
        try:
            sim = rvo.Simulator(scene, time_step=1 / 60, rng=np.random.default_rng(0))
            sim.add_agents(places, concourse.center, goal_region=concourse, radius=0.25, pref_speed=speeds,
                           max_speed=1.8)
            sim.step()
            frames, starts = [], []
            for _ in range(600):
                t = time.perf_counter()
                replan = sim.steps % sim.replan_steps == 0
                sim.step()
                frames.append(time.perf_counter() - t)
                if replan:
                    starts.append(frames[-1])
        finally:
            rvo.simulator.REPLAN_SPREAD_S = kept
        rows[label] = (np.median(frames), np.median(starts), max(frames))
    print("the stand (2000 walkers, one goal region) at 60 frames/s, 600 frames: " + "; ".join(
        f"re-solve {label}: {m * 1e3:.1f} ms median frame, {s * 1e3:.1f} ms the re-solve's first, "
        f"{w * 1e3:.1f} ms the worst" for label, (m, s, w) in rows.items()))


def wanderers_at_30_fps() -> None:
    scene = cm.Scene(bounds=([0, 0], [30, 30]), obstacles=[cm.Circle([15, 15], 2.5), cm.Box([4, 4], [7, 6])])
    keep_out = [((4.0, 4.0), (7.0, 6.0))]  # the stall, kept 1 m clear of

    def free(rng, n):
        p = rng.uniform(0.5, 29.5, (4 * n, 2))
        p = p[(np.linalg.norm(p - 15, axis=1) > 3.2) & np.array([_clear(q, keep_out) for q in p])]
        return p[:n]

    lattice = np.stack(np.meshgrid(np.arange(1.0, 29.5, 1.0), np.arange(1.0, 29.5, 1.0)), -1).reshape(-1, 2)
    lattice = lattice[(np.linalg.norm(lattice - 15, axis=1) > 3.2) & np.array([_clear(q, keep_out) for q in lattice])]
    rows, shipped = {}, None
    for label, cells in (("spread by what they hold", rvo.simulator.REPLAN_CELLS_PER_STEP),
                         ("within a quarter second", np.inf)):
        rvo.simulator.REPLAN_CELLS_PER_STEP, kept = cells, rvo.simulator.REPLAN_CELLS_PER_STEP
        try:
            rng = np.random.default_rng(0)
            sim = rvo.Simulator(scene, time_step=1 / 30, remove_on_arrival=False, rng=np.random.default_rng(0))
            with warnings.catch_warnings():  # 200 goal points in one call: grouped by place at first
                warnings.simplefilter("ignore")
                sim.add_agents(lattice[rng.choice(len(lattice), 200, replace=False)], free(rng, 200))
            frames, positions = [], []
            for _ in range(40 * 30):
                done = np.flatnonzero(sim.arrived)
                if len(done):
                    sim.set_goals(done, free(rng, len(done)), leave=False)
                t = time.perf_counter()
                sim.step()
                frames.append(time.perf_counter() - t)
                positions.append(sim.positions.copy())
        finally:
            rvo.simulator.REPLAN_CELLS_PER_STEP = kept
        f = np.array(frames[10 * 30:]) * 1e3
        rows[label] = (np.median(f), *np.percentile(f, [95, 99]), f.max())
        shipped = positions if len(rows) == 1 else shipped  # the motion as shipped: the first variant's
    print("200 wanderers with goals of their own at 30 frames/s, the last 30 s: " + "; ".join(
        f"re-solves {label}: frames {m:.1f} ms median, p95 {p95:.1f}, p99 {p99:.1f}, worst {w:.1f}"
        for label, (m, p95, p99, w) in rows.items()))
    p, h = np.array(shipped[5 * 30:]), 1 / 30  # every wanderer stays: all active
    speed = np.linalg.norm(p[2:] - p[:-2], axis=2) / (2 * h)
    accel = np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=2) / h ** 2
    v_in, v_out = p[1:-1] - p[:-2], p[2:] - p[1:-1]
    norm = np.linalg.norm(v_in, axis=2) * np.linalg.norm(v_out, axis=2)
    turn = np.arccos(np.clip(np.einsum("tik,tik->ti", v_in, v_out) / np.where(norm > 0, norm, 1), -1, 1)) / h
    moving = speed > 0.3
    print(f"  their motion (re-solves spread): acceleration p99 {np.percentile(accel[moving], 99):.2f} m/s², "
          f"{100 * np.mean(accel[moving] > 5):.2f} % of frames over 5 m/s²; turn rate p99 "
          f"{np.percentile(turn[moving], 99):.2f} rad/s; {speed[moving].mean():.2f} m/s on average")


def chased_point() -> None:
    boxes = [([8, 8], [16, 14]), ([22, 26], [30, 34]), ([34, 6], [42, 12])]
    scene = cm.Scene(bounds=([0, 0], [50, 40]), obstacles=[cm.Box(a, b) for a, b in boxes])
    sim = rvo.Simulator(scene, time_step=1 / 60, rng=np.random.default_rng(0))
    starts = np.stack(np.meshgrid(np.arange(1.0, 6.0), np.arange(1.0, 39.0, 1.9)), -1).reshape(-1, 2)[:100]
    ids = sim.add_agents(starts, [45, 20])
    for _ in range(5):
        sim.step()
    costs = []
    for k in range(120):
        point = [45.0 - 0.05 * k, 20.0 + 5 * np.sin(k / 20)]
        t = time.perf_counter()
        sim.set_goals(ids, point)
        costs.append(time.perf_counter() - t)
        sim.step()
    print(f"a point chased (100 walkers given a new goal point every frame, 60 frames/s): set_goals "
          f"{np.median(costs) * 1e3:.1f} ms median, {max(costs) * 1e3:.1f} ms at most")


if __name__ == "__main__":
    rvo.warm_up()
    wave_of_goals()
    wanderers()
    pushed_cart()
    stand_at_60_fps()
    wanderers_at_30_fps()
    chased_point()
