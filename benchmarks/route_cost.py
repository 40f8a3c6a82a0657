"""What a route costs an RVO agent per step, against the same agent with one goal.

The same 10 000 agents (radius 0.25 m, a jittered 0.8 m lattice, 125 x 80 agents) stand
in a 200 x 120 m hall with a row of pillars (so guidance follows distance fields):

- **one goal**: every agent leaves by the east exit (a 1 x 20 m strip, removed there);
- **route, same walk**: ``goto`` an area over the crowd's east third (those in it arrive
  at once, the others as they reach its west edge, walking east as before), then
  ``leave`` by the east exit: the walk of the one goal, with a stage change for every
  agent that reaches the area in the window. Its ratio to the one goal is the route's
  cost per agent per step;
- **route, mixed**: ``goto`` a 30 x 100 m area over the crowd's east part, ``wait``
  1-4 s (uniform), then ``choose`` the nearest of a west and an east exit and ``leave``
  there. Agents that wait stand still, which costs less than walking, so this one is
  cheaper than the one goal; it shows the stage changes and the choice at work.

A warm-up run of each variant (1000 agents) compiles the kernels first. Each run builds
its simulator, takes one untimed step (the fields are solved there), then times ``--steps`` steps (one thread). The two variants alternate, ``--runs`` times;
the table gives the median ms per step of each, the ratio, the share of the route's
steps spent in ``Journeys.update``, and the stage changes in the window.

Caching: every call of ``distance_fields`` (a field solve) is counted. After the first
step the route variant must solve none, whatever the stage changes (each stage's field
is solved up front with the others and looked up afterwards); the congestion-aware
re-solve every ``replan_s`` (2 s) runs in both variants and is counted apart.

    NUMBA_NUM_THREADS=1 python benchmarks/route_cost.py [--agents 10000] [--steps 40] [--runs 5]
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.groups import Rect
from crowdmotion.stages import Choose, GoTo, Leave, Wait

BOUNDS = ([0.0, 0.0], [200.0, 120.0])
EAST = Rect([199.0, 50.0], [200.0, 70.0])
WEST = Rect([0.0, 50.0], [1.0, 70.0])
SPACING = 0.8


class Counter:
    """Counts calls of a function it wraps (field solves, congestion re-solves, updates)
    and the seconds spent in them."""

    def __init__(self, fn):
        self.fn, self.calls, self.seconds = fn, 0, 0.0

    def __call__(self, *args, **kwargs):
        self.calls += 1
        t0 = time.perf_counter()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.seconds += time.perf_counter() - t0


def scene() -> cm.Scene:
    pillars = [cm.Box([x, 25.0], [x + 1.0, 26.0]) for x in range(40, 170, 10)]
    pillars += [cm.Box([x, 95.0], [x + 1.0, 96.0]) for x in range(40, 170, 10)]
    return cm.Scene(bounds=BOUNDS, obstacles=pillars)


def crowd(n: int) -> np.ndarray:
    cols = int(np.ceil(np.sqrt(n * 1.5625)))
    g = np.stack(np.meshgrid(np.arange(cols), np.arange(int(np.ceil(n / cols)))), -1).reshape(-1, 2)[:n]
    rng = np.random.default_rng(0)
    return [50.0, 28.0] + g * SPACING + rng.uniform(-0.1, 0.1, g.shape)


def route(pos: np.ndarray, kind: str) -> list:
    east = float(np.quantile(pos[:, 0], 0.7))
    if kind == "route, same walk":
        return [GoTo(Rect([east, 10.0], [float(pos[:, 0].max()) + 1.0, 110.0]), name="east third"),
                Leave(EAST, name="east")]
    return [GoTo(Rect([east, 10.0], [east + 30.0, 110.0]), name="square"),
            Wait({"uniform": [1.0, 4.0]}),
            Choose([Leave(WEST, name="west"), Leave(EAST, name="east")], by="nearest")]


def one_run(n: int, steps: int, kind: str) -> dict:
    """ms per step over ``steps`` steps after one untimed step, and what was solved."""
    from crowdmotion.rvo import simulator as S

    pos = crowd(n)
    sim = rvo.Simulator(scene(), rng=np.random.default_rng(1))
    ids = sim.add_agents(pos, EAST.nearest(pos), goal_region=EAST, arrive_anywhere=True)
    with_route = kind != "one goal"
    if with_route:
        sim.set_route(ids, route(pos, kind))
    sim.step()  # fields solved here, kernels compiled on the first run
    solves, original = Counter(S.distance_fields), S.distance_fields
    S.distance_fields = solves
    router = sim._router
    replans = Counter(router.resolve)
    router.resolve = replans
    update = None
    if with_route:
        update = Counter(sim.journeys.update)
        sim.journeys.update = update
        before = sim.journeys.stage.copy()
        changed = np.zeros(n, dtype=np.int64)
    try:
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
            if with_route:
                now = sim.journeys.stage
                changed += now != before
                before = now.copy()
        wall = time.perf_counter() - t0
    finally:
        S.distance_fields = original
    return {"ms": 1e3 * wall / steps, "solves": solves.calls, "replans": replans.calls,
            "replan_ms": 1e3 * replans.seconds / steps,
            "update_share": None if update is None else update.seconds / wall,
            "changes": int(changed.sum()) if with_route else 0,
            "left": int((~sim.active).sum())}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--agents", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)
    import numba

    print(f"{a.agents} agents, {a.steps} steps of 0.25 s timed per run, {a.runs} interleaved runs, "
          f"{numba.get_num_threads()} numba thread(s), {platform.processor() or platform.machine()}")
    runs = {"one goal": [], "route, same walk": [], "route, mixed": []}
    for name in runs:  # compile every kernel the variants use before timing
        one_run(min(a.agents, 1000), 8, name)
    for r in range(a.runs):
        for name in runs:
            out = one_run(a.agents, a.steps, name)
            runs[name].append(out)
            print(f"  run {r}: {name:16s} {out['ms']:7.1f} ms/step, field solves after step 1: {out['solves']}, "
                  f"congestion re-solves {out['replans']} ({out['replan_ms']:.1f} ms/step), "
                  f"stage changes {out['changes']}, left {out['left']}", flush=True)
    med = {k: float(np.median([o["ms"] for o in v])) for k, v in runs.items()}
    rep = {k: float(np.median([o["replan_ms"] for o in v])) for k, v in runs.items()}
    print()
    print("| variant | ms per step (median) | / one goal | congestion re-solve, ms per step | "
          "Journeys.update | stage changes per run | field solves after step 1 |")
    print("|---|---|---|---|---|---|---|")
    for k, v in runs.items():
        share = "" if k == "one goal" else f"{100 * float(np.median([o['update_share'] for o in v])):.1f} %"
        print(f"| {k} | {med[k]:.1f} | {med[k] / med['one goal']:.3f} | {rep[k]:.1f} | {share} | "
              f"{int(np.median([o['changes'] for o in v]))} | {max(o['solves'] for o in v)} |")


if __name__ == "__main__":
    main()
