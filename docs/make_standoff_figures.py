"""Make docs/img/rvo_standoffs.png: the RVO stand-off rules (crowdmotion.rvo.deadlock) at work.

    python docs/make_standoff_figures.py

Three panels, each a scene written from a public description rather than one of ours:
two walkers meeting head-on in a 4 m deep, 1.6 m wide doorway (SteerBench's doorway
two-way) with the rules off and on, the same in a one-body-wide passage (one yields), and
60 agents sharing one goal point with arrivals staying (arrival by contact).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import crowdmotion as cm  # noqa: E402
from crowdmotion import rvo  # noqa: E402
from crowdmotion.render.plots import _draw_obstacles_2d  # noqa: E402

IMG = Path(__file__).parent / "img"


def door(width: float, thickness: float) -> cm.Scene:
    lo, hi = 5 - width / 2, 5 + width / 2
    return cm.Scene(bounds=([0, 0], [20, 10]),
                    obstacles=[cm.Box([10 - thickness / 2, 0], [10 + thickness / 2, lo]),
                               cm.Box([10 - thickness / 2, hi], [10 + thickness / 2, 10])])


def head_on(scene: cm.Scene, **kw):
    sim = rvo.Simulator(scene, time_step=0.1, rng=np.random.default_rng(0), **kw)
    sim.add_agents([[5, 5]], [[16, 5]], radius=0.3)
    sim.add_agents([[15, 5]], [[4, 5]], radius=0.3)
    path = [sim.positions.copy()]
    while sim.time < 40 and sim.active.any():
        sim.step()
        path.append(np.where(sim.present[:, None], sim.positions, np.nan))
    return np.array(path), sim


def panel(ax, scene, path, sim, title):
    _draw_obstacles_2d(ax, scene)
    for k, colour in enumerate(("tab:blue", "tab:orange")):
        ax.plot(path[:, k, 0], path[:, k, 1], color=colour, lw=1.5)
        ax.plot(*path[0, k], "o", color=colour, mfc="none")
        last = path[~np.isnan(path[:, k, 0]), k][-1]
        ax.plot(*last, "o", color=colour)
    arrived = ", ".join("arrived %.0f s" % t if np.isfinite(t) else "never arrived" for t in sim.arrival_time)
    ax.set_title(f"{title}\n{arrived}", fontsize=9)
    ax.set_xlim(2, 18)
    ax.set_ylim(2, 8)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")


def main() -> None:
    fig, axes = plt.subplots(2, 2, figsize=(11, 6.5))
    deep = door(1.6, 4.0)
    # as tests/rvo/test_deadlock.py has it: no keep right, no yielding, no squeezing past,
    # eq. (3) without the comfort charge
    p, s = head_on(deep, keep_right_deg=0.0, patience=1e9, squeeze_past=False, comfort_accel=0.0)
    panel(axes[0, 0], deep, p, s, "deep doorway, rules off: both stand for good")
    p, s = head_on(deep)
    panel(axes[0, 1], deep, p, s, "deep doorway, rules on: they keep right and pass")
    narrow = door(0.9, 3.0)
    p, s = head_on(narrow)
    names = ("blue", "orange")
    later = int(np.nanargmax(s.arrival_time))
    panel(axes[1, 0], narrow, p, s, f"one-body passage: {names[later]} backs out and yields, "
                                    f"{names[1 - later]} passes")
    axes[0, 0].set_ylabel("y (m)")
    axes[1, 0].set_ylabel("y (m)")
    ax = axes[1, 1]
    scene = cm.Scene(bounds=([0, 0], [30, 20]))
    group = cm.Group("crowd", 60, spawn=cm.Rect([1, 1], [9, 19]), goal=cm.Points([[22, 10]]), radius=0.25)
    run = rvo.run(scene, [group], rvo.RVOParams(remove_on_arrival=False, max_steps=1200), np.random.default_rng(4))
    pos = run.trajectories.positions
    for k in range(pos.shape[1]):
        ax.plot(pos[:, k, 0], pos[:, k, 1], color="0.7", lw=0.5)
    ax.scatter(*pos[-1].T, s=12, color="tab:green", zorder=3)
    ax.plot(22, 10, "*", color="gold", mec="k", ms=12, zorder=4)
    sim = run.simulator
    ax.set_title(f"60 agents, one goal point, arrivals stay: {sim.arrived.sum()}/60 arrive\n"
                 f"({sim.stats['contact_arrivals']} by touching an arrived agent)", fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlim(0, 30)
    ax.set_ylim(0, 20)
    ax.set_xlabel("x (m)")
    fig.suptitle("RVO stand-offs: open circle = start, dot = end (crowdmotion.rvo.deadlock)")
    fig.tight_layout()
    out = IMG / "rvo_standoffs.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
