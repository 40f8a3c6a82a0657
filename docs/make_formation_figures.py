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
    "formation_split": ([(0.0, "(a) marching onto the planter"), (18.0, "(b) swinging round it"),
                         (30.0, "(c) edges to the vertices held back torn (red, dashed)"), (None, "(d) relinked and recovered")],
                        ((0.0, -10.0), (60.0, 10.0))),
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


def _strain_panel(ax, run, scene, step: int, window, title: str):
    """One group's mesh at ``step`` with each edge coloured by its length over its rest
    length (blue compressed, red stretched; torn edges dashed), obstacles where they are."""
    from matplotlib.collections import LineCollection

    from crowdmotion.render.plots import _draw_obstacles_2d

    g = run.simulator.groups[0]
    V = run.vertices[0][step]
    e = g.mesh.edges
    ratio = np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1) / g.mesh.rest_length
    torn = run.torn[0][step]
    _draw_obstacles_2d(ax, scene, step * run.simulator.dt)
    lines = LineCollection(V[e], array=np.log2(ratio), cmap="coolwarm", norm=plt.Normalize(-1, 1), lw=1.6,
                           linestyles=["--" if t else "-" for t in torn])
    ax.add_collection(lines)
    ax.plot(*run.frames[step][g.agents].T, ".", color="k", ms=2)
    (x0, y0), (x1, y1) = window
    ax.set(xlim=(x0, x1), ylim=(y0, y1), aspect="equal", xlabel="x (m)", ylabel="y (m)")
    ax.set_title(f"{title}, t = {step * run.simulator.dt:.1f} s", fontsize=10)
    return lines


def fig3() -> None:
    """Paper Fig. 3 from our runs: obstacles twist, compress, expand and tear the mesh."""
    paths = {p.stem: p for p in builtin_scenarios()}
    runs = {n: run_scenario(load_scenario(paths[n]), progress=False)
            for n in ("formation_traffic", "formation_army", "formation_split")}
    fig, axes = plt.subplots(2, 2, figsize=(13, 9), layout="constrained")
    traffic, army, split = (runs[n].extras for n in ("formation_traffic", "formation_army", "formation_split"))
    # twist: the step where a car turned furthest from the platoon's heading
    axis = traffic.frames[:, 1::2] - traffic.frames[:, 0::2]
    t_twist = int(np.argmax(np.abs(((np.arctan2(axis[..., 1], axis[..., 0]) - np.pi / 2 + np.pi) % (2 * np.pi))
                                   - np.pi).max(axis=1)))
    c = traffic.vertices[0][t_twist].mean(axis=0)
    _strain_panel(axes[0, 0], traffic, runs["formation_traffic"].scenario.scene, t_twist,
                  ((c[0] - 22, -4), (c[0] + 22, 11)), "(a) twist: the police car cuts through")
    V = army.vertices[0]
    in_gate = (V[..., 0] >= 48) & (V[..., 0] <= 50)
    t_gate = int(np.argmax(in_gate.sum(axis=1)))
    _strain_panel(axes[0, 1], army, runs["formation_army"].scenario.scene, t_gate, ((36, -10), (62, 10)),
                  "(b) compression: the gate")
    rocks = ((V[..., 0] > 20) & (V[..., 0] < 34)).any(axis=1)
    t_rocks = int(np.argmax(np.where(rocks, np.ptp(V[..., 1], axis=1), 0)))
    _strain_panel(axes[1, 0], army, runs["formation_army"].scenario.scene, t_rocks, ((14, -10), (40, 10)),
                  "(c) expansion: the rocks")
    t_torn = int(np.argmax(split.torn[0].sum(axis=1)))
    lines = _strain_panel(axes[1, 1], split, runs["formation_split"].scenario.scene, t_torn, ((10, -10), (40, 10)),
                          "(d) tearing: the planter (torn edges dashed)")
    bar = fig.colorbar(lines, ax=axes, shrink=0.6, ticks=[-1, -0.5, 0, 0.5, 1])
    bar.ax.set_yticklabels(["0.5x", "0.71x", "rest", "1.41x", "2x"])
    bar.set_label("edge length / rest length")
    fig.suptitle("Paper Fig. 3 from our runs: obstacles twist, compress, expand and tear the guiding mesh")
    fig.savefig(IMG / "formation_fig3.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    IMG.mkdir(exist_ok=True)
    templates_figure()
    arap_figure()
    scene_figures()
    fig3()
