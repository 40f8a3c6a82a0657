"""Make the figures and measured numbers of docs/pso.md.

    python docs/make_pso_figures.py

Writes docs/img/pso_*.png: the paper's Fig. 5 (pure gathering, particles as points),
the four built-in scenes, and the Fig. 2 demonstration (too many iterations per target
update lose the target's detail), and prints the numbers quoted in docs/pso.md.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crowdmotion import pso  # noqa: E402
from crowdmotion.cli import builtin_scenarios  # noqa: E402
from crowdmotion.groups import MovingTarget  # noqa: E402
from crowdmotion.render import plot_paths  # noqa: E402
from crowdmotion.scenario import load_scenario, run_scenario  # noqa: E402

IMG = Path(__file__).parent / "img"
SQUARE = MovingTarget([0.0, 50.0, 100.0, 150.0, 200.0], [[0, 0], [30, 0], [30, 30], [0, 30], [0, 0]])


def tracking(k: int):
    run = pso.follow(SQUARE, n_particles=20, start_range=((-5, -5), (5, 5)), rng=np.random.default_rng(0),
                     iterations=k, iteration_time=0.25, avoid_agents=False)
    t = np.arange(run.paths.shape[0]) * 0.25
    centre = run.paths.mean(axis=1)
    err = float(np.sqrt(np.mean(np.sum((centre - SQUARE.at(np.minimum(t, 200.0))) ** 2, axis=1))))
    return run, centre, err


def fig2() -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 5))
    for ax, k in zip(axes, (20, 100, 400)):
        run, centre, err = tracking(k)
        ax.plot(SQUARE.positions[:, 0], SQUARE.positions[:, 1], "k--", lw=1.5, label="target path")
        upd = np.unique(run.targets[:, 0], axis=0)
        ax.plot(upd[:, 0], upd[:, 1], "s", color="gold", mec="k", ms=7, label="target as read")
        for i in range(run.paths.shape[1]):
            ax.plot(run.paths[:, i, 0], run.paths[:, i, 1], "-", color="tab:blue", lw=0.4, alpha=0.4)
        ax.plot(centre[:, 0], centre[:, 1], "-", color="tab:red", lw=1.5, label="swarm centre")
        ax.set_title(f"k = {k} iterations per update: RMS lag {err:.2f} m")
        ax.set_aspect("equal")
        ax.set_xlim(-8, 38)
        ax.set_ylim(-8, 38)
        print(f"k = {k:3d}: RMS distance swarm centre - target {err:.2f} m")
    axes[0].legend(loc="center", fontsize=8)
    fig.suptitle("Target following: the more iterations per target update, the more of the target's motion is lost "
                 "(paper Fig. 2)")
    fig.savefig(IMG / "pso_fig2_iterations.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def fig5_points() -> None:
    run = pso.gather(rng=np.random.default_rng(1), avoid_agents=False)
    print(f"pure gathering: {run.paths.shape[0] - 1} iterations, "
          f"{100 * run.within_threshold().mean():.0f}% within the threshold")
    plot_paths(run.trajectories(["swarm"]), run.scene, IMG / "pso_fig5_points.png",
               title="Paper Fig. 5: 30 particles gather on (0, 0, 0), agent avoidance off", goals=[[0, 0, 0]])


def scenes() -> None:
    for path in builtin_scenarios():
        if not path.stem.startswith("pso_"):
            continue
        sc = load_scenario(path)
        res = run_scenario(sc, progress=False)
        s = res.summary
        print(f"{path.stem}: {s['iterations']} iterations, arrival {100 * s['arrival_rate']:.0f}%, "
              f"overlaps {s['agent_agent_overlaps']}, penetrations {s['agent_obstacle_penetrations']}, "
              f"rule conflicts {s['rules']['rule_conflicts']}, cuts {s['rules']['separation_truncations']} "
              f"+ stops {s['rules']['separation_stops']}, redirects {s['rules']['obstacle_redirects']} obstacle / "
              f"{s['rules']['agent_redirects']} agent")
        targets = np.unique(res.extras.swarm_run.targets.reshape(-1, sc.scene.dim), axis=0)
        plot_paths(res.trajectories, res.extras.scene, IMG / f"{path.stem}.png", title=sc.spec.description,
                   goals=targets)
        if path.stem == "pso_avoidance":
            avoidance_detail(res, sc.scene)


def avoidance_detail(res, scene) -> None:
    """Fig. 7 close up: (a) the screen seen along the flight, with the point where each
    particle passed it; (b) the paths near the screen, seen from above, of the particles
    that passed in the busiest row of spheres, with that row."""
    from matplotlib import patches

    p = res.trajectories.positions
    spheres = [o for o in scene.obstacles if hasattr(o, "radius")]
    cross = []
    for i in range(p.shape[1]):
        k = np.flatnonzero((p[:-1, i, 0] < 0) & (p[1:, i, 0] >= 0))
        if len(k):
            a, b = p[k[0], i], p[k[0] + 1, i]
            cross.append(a + (b - a) * (-a[0]) / (b[0] - a[0]))
    cross = np.array(cross)
    rows = np.unique([o.center[2] for o in spheres])
    busiest = rows[np.argmax([np.sum(np.abs(cross[:, 2] - z) < 2.5) for z in rows])]
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 6), layout="constrained")
    for o in spheres:
        a.add_patch(patches.Circle(o.center[1:], o.radius, color="0.6"))
        if o.center[2] == busiest:
            b.add_patch(patches.Circle(o.center[:2], o.radius, color="0.6"))
    a.plot(cross[:, 1], cross[:, 2], "o", color="C0", ms=5, label="where a particle passed the screen (x = 0)")
    a.set(xlim=(scene.lower[1], scene.upper[1]), ylim=(scene.lower[2], scene.upper[2]), aspect="equal",
          xlabel="y (m)", ylabel="z (m)", title="(a) the screen of spheres, seen along the flight")
    a.legend(loc="upper right", fontsize=8)
    near = (p[..., 0] > -8) & (p[..., 0] < 8)
    for i in np.flatnonzero(np.abs(cross[:, 2] - busiest) < 2.5):
        m = near[:, i]
        b.plot(p[m, i, 0], p[m, i, 1], "-", color="C0", lw=0.8)
    b.set(xlim=(-8, 8), aspect="equal", xlabel="x (m)", ylabel="y (m)",
          title=f"(b) paths through the row at z = {busiest:g} m, seen from above")
    s = res.summary["rules"]
    fig.suptitle(f"Fig. 7 close up: {s['particles_redirected']} of {p.shape[1]} particles redirected by eqs. (4)-(5) "
                 f"({s['obstacle_redirects']} redirects), 0 penetrations")
    fig.savefig(IMG / "pso_avoidance_detail.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    IMG.mkdir(exist_ok=True)
    fig5_points()
    fig2()
    scenes()
