"""Make the figures of docs/formation.md.

    python docs/make_formation_figures.py

Writes docs/img/formation_*.png: the mesh of each template, an ARAP deformation (two
handles pulled), and the built-in scenes (army, traffic, exchange) at the moments the
paper's Figs. 6-8 show, and prints each scene's formation measures.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crowdmotion import formation  # noqa: E402
from crowdmotion.cli import builtin_scenarios  # noqa: E402
from crowdmotion.render import plot_formation_snapshots  # noqa: E402
from crowdmotion.scenario import load_scenario, run_scenario  # noqa: E402

IMG = Path(__file__).parent / "img"
# (scene, [(time s, label)], crop window) — the moments of the paper's figures
SCENES = {
    "formation_army": ([(0.0, "(a) initial formation"), (16.0, "(b) spreading through rocks"),
                        (40.0, "(c) compressed in the gate"), (None, "(d) recovered")],
                       ((0.0, -15.0), (100.0, 15.0))),
    "formation_traffic": ([(6.0, "(a) police car at the junction"), (7.5, "(b) merged in: twist"),
                           (10.5, "(c) expansion round the police car"), (None, "(d) recovered")],
                          ((15.0, -12.0), (200.0, 13.0))),
    "formation_exchange": ([(0.0, "(a) initial formations"), (14.0, "(b) passing each other"),
                            (None, "(c) recovered, places exchanged")], ((0.0, -12.0), (60.0, 12.0))),
}


def _mesh_panel(ax, points, triangles, title: str) -> None:
    ax.triplot(points[:, 0], points[:, 1], triangles, color="C0", lw=0.8)
    ax.set_aspect("equal")
    ax.set_title(title)


def _save(fig, name: str, title: str) -> None:
    fig.suptitle(title)
    fig.savefig(IMG / name, dpi=100, bbox_inches="tight")
    plt.close(fig)


def templates_figure() -> None:
    tpls = {"block(6, 8)": formation.block(6, 8), "wedge(5)": formation.wedge(5),
            "circle(16, 4 m)": formation.circle(16, 4.0), "cars(2 lanes, 4 each)": formation.cars(2, 4)}
    fig, axes = plt.subplots(1, 4, figsize=(16, 4))
    for ax, (name, tpl) in zip(axes, tpls.items()):
        _mesh_panel(ax, tpl.points, formation.FormationMesh(tpl.points).triangles, name)
        ax.plot(tpl.points[:, 0], tpl.points[:, 1], "o", color="C1", ms=4)
        for a, b in tpl.pairs:
            ax.plot(*tpl.points[[a, b]].T, color="k", lw=3)
    _save(fig, "formation_templates.png",
          "Formation meshes (Delaunay over the rest positions; cars: each black bar is one car)")


def arap_figure() -> None:
    mesh = formation.FormationMesh(formation.block(8, 8, 1.0).points)
    solver = formation.ARAPSolver(mesh)
    h = np.array([0, 7, 56, 63])  # the four corners
    q = mesh.rest[h].copy()
    cases = {"rest": None, "two corners pushed in (compression)": q + [[0, -1.5], [0, 0], [0, -1.5], [0, 0]],
             "one side turned (twist)": q + [[0, 0], [0, 0], [3.0, 2.0], [3.0, -1.0]]}
    fig, axes = plt.subplots(1, 3, figsize=(15, 5))
    for ax, (name, tgt) in zip(axes, cases.items()):
        _mesh_panel(ax, mesh.rest if tgt is None else solver.deform(h, tgt), mesh.triangles, name)
        if tgt is not None:
            ax.plot(tgt[:, 0], tgt[:, 1], "s", color="C3", ms=8, label="handles")
            ax.legend(loc="upper right")
    _save(fig, "formation_arap.png", "Two-step as-rigid-as-possible deformation: only the four corner handles are set")


def scene_figures() -> None:
    paths = {p.stem: p for p in builtin_scenarios()}
    for name, (moments, window) in SCENES.items():
        result = run_scenario(load_scenario(paths[name]), progress=False)
        run = result.extras
        last = len(run.frames) - 1
        snaps = []
        for t, label in moments:
            step = last if t is None else min(int(round(t / run.simulator.dt)), last)
            snaps.append({"time": step * run.simulator.dt, "label": label, "groups": run.snapshot(step)})
        plot_formation_snapshots(result.scenario.scene, snaps, IMG / f"{name}.png", window=window)
        s = result.summary
        print(f"{name}: overlaps {s['agent_agent_overlaps']}, penetrations {s['agent_obstacle_penetrations']}, "
              f"steps {s['steps']}")
        for g, rep in s["formation"].items():
            print(f"  {g}: final edge error {rep['edge_length_error_mean']:.4f} (max {rep['edge_length_error_max']:.3f}),"
                  f" worst mean {rep['worst_mean_edge_length_error']:.3f}, Kabsch RMS {rep['kabsch_rms_m']:.3f} m, "
                  f"recovered at {rep['recovered_s']:.1f} s, recovery after obstacles "
                  f"{rep['recovery_after_obstacles_s']} s, dislocations {rep['dislocations']}, "
                  f"torn {rep['edges_torn']}, factorisations {rep['factorisations']}")


if __name__ == "__main__":
    IMG.mkdir(exist_ok=True)
    templates_figure()
    arap_figure()
    scene_figures()
