"""Make the diversity figure of docs/mdp.md (paper 000 §3.2, Figs. 1-2).

    python docs/make_mdp_figures.py

The paper runs each of its two scenes three times (30 robots on the ground, 30 drones
in the air; the same starts and goal every time) and shows that the agents stand in
slightly different places at the same frame. This runs the built-in mdp_diversity (the
robots of mdp_robots_2d from listed starts) and mdp_drones_3d with its starts fixed to
those of its own seed, each with seeds 1, 2 and 3, draws the three runs' agents at three
moments over each other, and prints crowdmotion.metrics.diversity for each.
Writes docs/img/mdp_diversity.png.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crowdmotion.cli import builtin_scenarios  # noqa: E402
from crowdmotion.metrics import diversity  # noqa: E402
from crowdmotion.render.plots import _draw_obstacles_2d  # noqa: E402
from crowdmotion.scenario import PointsRegion, build, load_scenario, run_scenario  # noqa: E402

IMG = Path(__file__).parent / "img"
SCENES = ("mdp_diversity", "mdp_drones_3d")
SEEDS = (1, 2, 3)
MOMENTS = (0.25, 0.5, 0.75)  # shares of the shortest run


def fixed_starts(sc):
    """The scenario with every group's spawn replaced by the points its own seed draws
    (the same starts whatever the run's seed, as in the paper's experiment)."""
    first = run_scenario(sc, progress=False).trajectories
    groups = [g.model_copy(update={"spawn": PointsRegion(shape="points", points=[
        list(map(float, p)) for p in first.positions[0][first.group == g.name]])}) for g in sc.spec.groups]
    return build(sc.spec.model_copy(update={"groups": groups}), sc.spec.name)


def main() -> None:
    paths = {p.stem: p for p in builtin_scenarios()}
    fig, axes = plt.subplots(len(SCENES), len(MOMENTS), figsize=(5 * len(MOMENTS), 4.6 * len(SCENES)),
                             layout="constrained", squeeze=False)
    for row, name in zip(axes, SCENES):
        sc = fixed_starts(load_scenario(paths[name]))
        runs = [run_scenario(sc, seed=s, progress=False) for s in SEEDS]
        trajs = [r.trajectories for r in runs]
        d = diversity(trajs)
        print(f"{name}: seeds {SEEDS}: mean distance at the same frame {d['mean_distance_m']:.2f} m, "
              f"max {d['max_distance_m']:.2f} m, {100 * d['share_apart']:.0f} % of agent-frames apart, "
              f"first apart at {d['first_apart_s']} s; overlaps "
              f"{[r.summary['agent_agent_overlaps'] for r in runs]}, penetrations "
              f"{[r.summary['agent_obstacle_penetrations'] for r in runs]}")
        t = min(tr.n_frames for tr in trajs)
        for ax, share in zip(row, MOMENTS):
            f = int(share * (t - 1))
            _draw_obstacles_2d(ax, sc.scene, f * trajs[0].dt)
            for k, (seed, tr) in enumerate(zip(SEEDS, trajs)):
                p = tr.positions[f][tr.active_mask[f]]
                ax.scatter(p[:, 0], p[:, 1], s=22, facecolors="none" if k else f"C{k}", edgecolors=f"C{k}",
                           marker="os^"[k], label=f"seed {seed}", zorder=3 + k)
            lo, hi = sc.scene.lower, sc.scene.upper
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_aspect("equal")
            ax.set_title(f"{name}, frame {f} (t = {f * trajs[0].dt:.1f} s): "
                         f"{d['by_frame_m'][f]:.2f} m apart on average", fontsize=9)
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
        row[-1].legend(loc="upper right", fontsize=8)
    fig.suptitle("Diversity (000 §3.2): three runs, the same starts and goal, agents at the same frames"
                 " (3D: seen from above)")
    fig.savefig(IMG / "mdp_diversity.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
