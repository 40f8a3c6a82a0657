"""Matplotlib figures: agent paths over the scene, MDP value fields, formation meshes\n(panels and animated GIFs)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import patches  # noqa: E402
from matplotlib.collections import EllipseCollection, LineCollection  # noqa: E402
from matplotlib.colors import to_rgb, to_rgba  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from crowdmotion.io.atomic import atomic_path  # noqa: E402
from crowdmotion.render.colours import group_colours  # noqa: E402
from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere  # noqa: E402
from crowdmotion.trajectories import Trajectories  # noqa: E402


def _save(fig, path: Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png", bbox_inches="tight")
    plt.close(fig)
    return path


def _draw_obstacles_2d(ax, scene: Scene, t: float = 0.0, moving: bool | None = None,
                       animated: bool = False, at_t: bool = False) -> list:
    """The scene's obstacles seen from above (3D shapes projected on x, y): all of them,
    or (``moving`` True / False) only those that change (move, or stand for part of the
    run: added or removed while running) / the others; a moving one's path as a dashed
    line. With ``at_t`` the picture is of time ``t``: an obstacle stands in it only if it
    stands at ``t`` (``Obstacle.present``); without, it is a whole run's picture, where
    an obstacle that stood for part of the run is a dashed outline. Returns
    ``[(obstacle, patch)]`` for the shapes drawn (``animated``: left out of a full draw,
    for blitting with :func:`move_obstacles`, which shows each only while it stands)."""
    drawn = []
    for ob in scene.obstacles:
        changes = ob.is_moving or ob.is_timed
        if moving is not None and changes != moving:
            continue
        standing = bool(ob.present_at(t))
        if at_t and not standing and not animated:
            continue
        shift = ob.offset(t)[:2]
        style = dict(**_obstacle_look(ob.is_moving), zorder=2, animated=animated and changes)
        if ob.is_timed and not at_t:  # stood for part of the run only
            style.update(facecolor="none", linestyle="--", linewidth=1.2, alpha=0.9)
        if isinstance(ob, (Circle, Sphere)):
            patch = ax.add_patch(patches.Circle(ob.center[:2] + shift, ob.radius, **style))
        elif isinstance(ob, Box):
            lo = ob.lower[:2] + shift
            patch = ax.add_patch(patches.Rectangle(lo, *(ob.upper[:2] - ob.lower[:2]), **style))
        elif isinstance(ob, Polygon):
            patch = ax.add_patch(patches.Polygon(ob.vertices + shift, closed=True, **style))
        else:
            continue
        patch.set_visible(standing or not at_t)
        drawn.append((ob, patch))
        if ob.is_moving:
            ax.plot(ob.path.positions[:, 0], ob.path.positions[:, 1], "k--", lw=1, zorder=2)
    return drawn


def _obstacle_look(moving: bool) -> dict:
    """How an obstacle is filled seen from above (the legend's patch draws the same)."""
    return dict(facecolor="0.35", edgecolor="0.1", alpha=0.5 if moving else 0.85)


def move_obstacles(ax, drawn: list, t: float, t0: float = 0.0) -> list:
    """Changing obstacles drawn at time ``t0`` by :func:`_draw_obstacles_2d`, shifted to
    where they are at ``t`` (the same patches, translated) and shown only if they stand
    at ``t``. Returns the patches."""
    from matplotlib.transforms import Affine2D

    for ob, patch in drawn:
        dx, dy = (ob.offset(t) - ob.offset(t0))[:2]
        patch.set_transform(Affine2D().translate(dx, dy) + ax.transData)  # after the patch's own
        patch.set_visible(bool(ob.present_at(t)))
    return [patch for _, patch in drawn]


def _group_colours(traj: Trajectories) -> dict:
    return group_colours(traj.group.tolist())


MAX_ASPECT = 6.0  # a scene's picture is at most this many times longer than high (or higher than long)
TITLE_WIDTH = 90  # characters a title's line holds before it wraps (the figure keeps its width)
ZOOM_SHARE = 0.25  # paths spanning less than this share of the bounds along both axes: drawn zoomed in
ZOOM_PAD = 0.15    # ... padded by this share of their span
ZOOM_PAD_M = 2.0   # ... or these metres, whichever is more
MAX_PATHS = 400  # more paths than this turn into a solid block: draw an even sample


def legend_outside(ax, handles, title: str | None = None) -> None:
    """The legend to the right of the axes, where it covers no agent."""
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title=title,
              title_fontsize=8, frameon=False)


def marker_handles(to_scale: bool = True) -> list:
    """Legend entries that explain the start and end markers (``to_scale``: the ends are
    the bodies, as in 2D; in 3D they are dots)."""
    return [Line2D([], [], marker="o", ls="", mfc="none", mec="0.3", ms=5, label="start"),
            Line2D([], [], marker="o", ls="", color="0.3", ms=6, label="end (body to scale)" if to_scale else "end")]


TORN_EDGE = dict(color="red", alpha=0.6, linestyle="--")  # how a torn mesh edge is drawn


def polyline_xy(segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m, 2, 2) segments as one polyline's x and y, the segments apart by NaN gaps: one
    path for matplotlib to stroke (a LineCollection makes a Path per segment, which cost
    half of a formation GIF's time)."""
    xy = np.full((len(segments), 3, 2), np.nan)
    xy[:, :2] = segments
    return xy[:, :, 0].ravel(), xy[:, :, 1].ravel()


def _mesh_lines(colour, lw: float, alpha: float, intact=None, torn=None, animated: bool = False) -> tuple:
    """A formation mesh's intact edges (in ``colour``) and torn edges (``TORN_EDGE``) as
    two lines, each one NaN-broken polyline of the (m, 2, 2) segments."""
    empty = np.empty((0, 2, 2))
    lines = (Line2D([], [], linewidth=lw, zorder=3, color=colour, alpha=alpha, animated=animated),
             Line2D([], [], linewidth=lw, zorder=3, animated=animated, **TORN_EDGE))
    for line, segments in zip(lines, (intact, torn)):
        line.set_data(*polyline_xy(empty if segments is None else segments))
    return lines


def _draw_mesh(ax, vertices: np.ndarray, edges: np.ndarray, torn: np.ndarray, colour, lw: float,
               alpha: float) -> None:
    """A formation mesh: intact edges in ``colour``, torn ones red and dashed."""
    segments = vertices[edges][:, :, :2]
    for sel, line in zip((~torn, torn), _mesh_lines(colour, lw, alpha, segments[~torn], segments[torn])):
        if sel.any():
            ax.add_line(line)


def _mesh_artists(ax, colour, lw: float, alpha: float) -> tuple:
    """Empty, animated artists for one formation in an animation: intact edges, torn
    edges and agents (points), styled as the snapshots draw them; fill them with
    ``set_data(*polyline_xy(segments))`` / ``set_offsets``."""
    intact, torn = _mesh_lines(colour, lw, alpha, animated=True)
    for line in (intact, torn):
        ax.add_line(line)
    dots = ax.scatter(np.empty(0), np.empty(0), s=8, zorder=4, animated=True)
    return intact, torn, dots


def blit_frame(fig, ax, background, artists: list, last: list) -> np.ndarray:
    """Restore ``background`` (``fig.canvas.copy_from_bbox``), draw ``artists`` in
    matplotlib's order (by zorder, ties in the order they were added), then ``last``;
    the figure's (H, W, 4) RGBA pixels as a view into the canvas."""
    fig.canvas.restore_region(background)
    for artist in sorted(artists, key=lambda a: a.get_zorder()) + list(last):
        ax.draw_artist(artist)
    return np.asarray(fig.canvas.buffer_rgba())


def _rgb_image(pixels: np.ndarray):
    """An (H, W, 3) RGB or (H, W, 4) RGBA uint8 array as a Pillow RGB image."""
    from PIL import Image

    pixels = np.ascontiguousarray(pixels)
    mode = "RGBA" if pixels.shape[2] == 4 else "RGB"
    image = Image.frombuffer(mode, (pixels.shape[1], pixels.shape[0]), pixels, "raw", mode, 0, 1)
    return image.convert("RGB")


GIF_RAMP_STEPS = 24  # shades from white to each colour in a GIF's palette swatch


def gif_palette(first: np.ndarray, colours=()):
    """One palette for every frame of a GIF: Pillow's fast octree over the first frame
    together with ramps from white to each of ``colours`` and to red and black (what
    later frames add: agents, trails and torn edges drawn with alpha over the white
    ground). Returns a palette image for :func:`gif_image`."""
    from PIL import Image

    rgb = np.asarray(_rgb_image(first))
    ramps = []
    for c in list(colours) + ["red", "black"]:
        t = np.linspace(0.0, 1.0, GIF_RAMP_STEPS)[:, None]
        ramps.append(np.round(255 * ((1 - t) + t * np.asarray(to_rgb(c))[None, :])))
    swatch = np.repeat(np.concatenate(ramps)[None], 8, axis=0).astype(np.uint8)  # 8 rows: weight in the octree
    width = max(rgb.shape[1], swatch.shape[1])
    pad = lambda a: np.pad(a, ((0, 0), (0, width - a.shape[1]), (0, 0)), constant_values=255)  # noqa: E731
    both = np.ascontiguousarray(np.concatenate([pad(rgb), pad(swatch)]))
    return Image.fromarray(both).quantize(colors=256, method=Image.Quantize.FASTOCTREE)


def gif_image(pixels: np.ndarray, palette=None):
    """An (H, W, 3|4) uint8 image as one palette image of a GIF: in ``palette`` (from
    :func:`gif_palette`; a lookup, 8x faster than quantizing each frame), or else with
    the frame's own 256 colours (Pillow's fast octree, 5x faster than median cut)."""
    from PIL import Image

    image = _rgb_image(pixels)
    if palette is None:
        return image.quantize(colors=256, method=Image.Quantize.FASTOCTREE)
    return image.quantize(palette=palette, dither=Image.Dither.NONE)


def write_gif(frames: list, path, fps: float) -> None:
    """Palette images (from :func:`gif_image`) as a looping GIF at ``fps``."""
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:], duration=int(1000 / fps), loop=0)


FEW_TARGETS = 20  # up to this many goals are targets drawn as stars over the paths; more are goal cells


def _view_2d(traj: Trajectories, scene: Scene, drawn: np.ndarray, goals, goal_paths) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of the 2D picture: the scene's bounds, or, where the paths (with the
    goals and targets' paths) take up under ZOOM_SHARE of them along both axes (a few
    walkers in SteerSuite's 200 m world), the box round them padded by ZOOM_PAD (at least
    ZOOM_PAD_M), within the bounds."""
    lo, hi = np.asarray(scene.lower[:2], float), np.asarray(scene.upper[:2], float)
    pts = [traj.positions[traj.active_mask[:, i], i, :2] for i in drawn]
    pts += [np.atleast_2d(goals)[:, :2]] if goals is not None else []
    pts += [np.asarray(t)[:, :2] for t in goal_paths or []]
    pts = np.concatenate([p for p in pts if len(p)]) if any(len(p) for p in pts) else np.zeros((0, 2))
    if not len(pts):
        return lo, hi
    a, b = pts.min(axis=0), pts.max(axis=0)
    if np.any(b - a >= ZOOM_SHARE * (hi - lo)):
        return lo, hi
    pad = np.maximum(ZOOM_PAD * (b - a).max(), ZOOM_PAD_M)
    return np.maximum(a - pad, lo), np.minimum(b + pad, hi)


def plot_paths(traj: Trajectories, scene: Scene, path, title: str = "", goals=None, goal_paths=None) -> Path:
    """Every agent's path (start ○, end ●) over the scene's obstacles; 2D or 3D; with
    ``goals`` marked and ``goal_paths`` (polylines: moving targets as followed) dashed."""
    colours = _group_colours(traj)
    act = traj.active_mask
    drawn = np.arange(traj.n_agents)
    if traj.n_agents > MAX_PATHS:  # an even sample: every group keeps its share
        drawn = drawn[np.linspace(0, traj.n_agents - 1, MAX_PATHS).astype(int)]
    note = f" ({len(drawn)} of {traj.n_agents} paths drawn)" if len(drawn) < traj.n_agents else ""
    if traj.dim == 2:
        # a scene far longer than wide (a 120 x 4 m corridor) drawn to scale is a strip a
        # few pixels high: y is drawn stretched (or, far taller than wide, squeezed) to
        # MAX_ASPECT, and the title says so
        lo, hi = _view_2d(traj, scene, drawn, goals, goal_paths)
        if np.any(lo > np.asarray(scene.lower[:2])) or np.any(hi < np.asarray(scene.upper[:2])):
            note += ", zoomed to the paths"
        shape = (hi[1] - lo[1]) / (hi[0] - lo[0])
        aspect = float(np.clip(shape, 1 / MAX_ASPECT, MAX_ASPECT)) / shape
        if abs(aspect - 1.0) > 1e-9:
            note += f", y scale × {aspect:.2g}"
        width = 8 * min(1.0, 1.5 / (shape * aspect))  # a tall scene: narrower, not metres high
        fig, ax = plt.subplots(figsize=(width, width * shape * aspect + 0.8))
        _draw_obstacles_2d(ax, scene)
        # one collection each for the paths, starts and ends (an artist per agent cost
        # 2 ms an agent)
        walks = [traj.positions[act[:, i], i, :2] for i in drawn]
        rgba = np.array([to_rgba(colours[traj.group[i]]) for i in drawn]).reshape(-1, 4)
        ax.add_collection(LineCollection(walks, colors=rgba, linewidths=0.8, alpha=0.7, zorder=3))
        ends = np.array([w[-1] for w in walks]).reshape(-1, 2)
        ax.scatter([w[0, 0] for w in walks], [w[0, 1] for w in walks], s=16, facecolors="none", edgecolors=rgba,
                   linewidths=1.0, zorder=4)
        ax.add_collection(EllipseCollection(2 * traj.radius[drawn], 2 * traj.radius[drawn] / aspect, 0.0, units="xy",
                                            offsets=ends, offset_transform=ax.transData, facecolors=rgba,
                                            edgecolors=rgba, zorder=5), autolim=False)
        for track in goal_paths or []:
            ax.plot(track[:, 0], track[:, 1], "--", color="darkgoldenrod", lw=1.6, zorder=5)  # over the paths
        if goals is not None:
            g = np.atleast_2d(goals)
            if len(g) > FEW_TARGETS:  # goal cells: a faint area under the paths
                ax.plot(g[:, 0], g[:, 1], "s", color="gold", alpha=0.35, ms=6, zorder=1)
            else:  # a few targets: on top, where the bodies that reach them do not hide them
                ax.plot(g[:, 0], g[:, 1], "*", color="gold", mec="k", mew=0.7, ms=13, zorder=6)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect(aspect)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    else:
        fig = plt.figure(figsize=(9, 8))
        ax = fig.add_subplot(projection="3d")
        for ob in scene.obstacles:
            if isinstance(ob, Sphere):
                u, v = np.mgrid[0 : 2 * np.pi : 24j, 0 : np.pi : 12j]
                ax.plot_surface(ob.center[0] + ob.radius * np.cos(u) * np.sin(v),
                                ob.center[1] + ob.radius * np.sin(u) * np.sin(v),
                                ob.center[2] + ob.radius * np.cos(v), color="0.5", alpha=0.35)
            elif isinstance(ob, Box):
                _box_3d(ax, ob.lower, ob.upper)
        for i in drawn:
            p = traj.positions[act[:, i], i]
            c = colours[traj.group[i]]
            ax.plot(p[:, 0], p[:, 1], p[:, 2], "-", color=c, lw=0.8, alpha=0.8)
            ax.scatter(*p[0], facecolors="none", edgecolors=c, s=16)
            ax.scatter(*p[-1], color=c, s=12)
        for track in goal_paths or []:
            ax.plot(track[:, 0], track[:, 1], track[:, 2], "--", color="darkgoldenrod", lw=1.6)
        if goals is not None:
            g = np.atleast_2d(goals)
            if len(g) > FEW_TARGETS:  # goal cells: a gold box round them (faint dots alone vanish in 3D)
                ax.scatter(g[:, 0], g[:, 1], g[:, 2], marker="s", color="gold", alpha=0.5, s=10)
                _box_3d(ax, g.min(axis=0), g.max(axis=0), face="gold", edge="darkgoldenrod", alpha=0.25)
            else:
                ax.scatter(g[:, 0], g[:, 1], g[:, 2], marker="*", color="gold", edgecolor="k", s=200)
        ax.set_xlim(scene.lower[0], scene.upper[0])
        ax.set_ylim(scene.lower[1], scene.upper[1])
        ax.set_zlim(scene.lower[2], scene.upper[2])
        ax.set_box_aspect(tuple(np.asarray(scene.upper, float) - np.asarray(scene.lower, float)))  # spheres round
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
    handles = [patches.Patch(color=c, label=n) for n, c in colours.items()]
    handles += marker_handles(to_scale=traj.dim == 2)
    if goals is not None:
        if len(np.atleast_2d(goals)) > FEW_TARGETS:
            handles.append(Line2D([], [], marker="s", ls="", color="gold", alpha=0.5, label="goal cells"))
        else:
            handles.append(Line2D([], [], marker="*", ls="", color="gold", mec="k", mew=0.7, ms=11, label="targets"))
    if goal_paths:
        handles.append(Line2D([], [], ls="--", color="darkgoldenrod", lw=1.6, label="target's path, as followed"))
    if traj.dim == 2 and any(not (ob.is_moving or ob.is_timed) for ob in scene.obstacles):
        handles.append(patches.Patch(**_obstacle_look(False), label="obstacle"))  # small rocks look like end dots
    if traj.dim == 2 and any(ob.is_moving for ob in scene.obstacles):  # paths cross where it stood at the start
        handles.append(patches.Patch(**_obstacle_look(True), label="moving obstacle, at the start"))
        handles.append(Line2D([], [], ls="--", color="k", lw=1, label="its path"))
    legend_outside(ax, handles)
    ax.set_title(textwrap.fill((title or f"{traj.n_agents} agents, {traj.n_frames} frames") + note, TITLE_WIDTH))
    return _save(fig, path)


def _box_3d(ax, lo, hi, face: str = "0.5", edge: str = "0.2", alpha: float = 0.3) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    x0, y0, z0 = lo
    x1, y1, z1 = hi
    faces = [
        [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
    ]
    ax.add_collection3d(Poly3DCollection(faces, facecolor=face, edgecolor=edge, alpha=alpha))


def plot_values(values: np.ndarray, path, cell_size: float = 1.0, origin=(0.0, 0.0), title: str = "",
                goal_cells=None) -> Path:
    """Heat map of the distance to goal |v(s)| (obstacles dark, unreachable hatched).

    3D fields show the horizontal slice through the first goal cell.
    """
    v = np.asarray(values, dtype=float)
    note = ""
    if v.ndim == 3:
        k = int(goal_cells[0][2]) if goal_cells is not None else v.shape[2] // 2
        v = v[:, :, k]
        lo = (origin[2] if len(origin) > 2 else 0.0) + k * cell_size
        note = f" (the slice z = {lo:.2f}-{lo + cell_size:.2f} m)"
        if goal_cells is not None:  # the goal cells in this slice
            goal_cells = np.asarray(goal_cells)[np.asarray(goal_cells)[:, 2] == k]
    dist = np.where(np.isfinite(v), -v, np.nan)
    fig, ax = plt.subplots(figsize=(8, 8 * v.shape[1] / v.shape[0] + 0.8))
    extent = (origin[0], origin[0] + v.shape[0] * cell_size, origin[1], origin[1] + v.shape[1] * cell_size)
    cmap = plt.get_cmap("viridis").with_extremes(bad="0.15")
    im = ax.imshow(dist.T, origin="lower", extent=extent, cmap=cmap, interpolation="nearest")
    if np.isfinite(dist).any():
        ax.contour(dist.T, levels=12, colors="w", linewidths=0.5, alpha=0.6, origin="lower", extent=extent)
    if goal_cells is not None:
        g = (np.asarray(goal_cells)[:, :2] + 0.5) * cell_size + np.asarray(origin[:2])
        ax.plot(g[:, 0], g[:, 1], "*", color="gold", mec="k", ms=10)
    fig.colorbar(im, ax=ax, label="path distance to goal |v(s)| (cells)", shrink=0.8)
    ax.set_title((title or "MDP state values") + note)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return _save(fig, path)


REPORT_PANELS = (
    ("lateral_spread_m", "lateral spread (m)"),
    ("heading_change_rate_rad_s", "heading change (rad/s)"),
    ("mixing_index", "mixing with the other group"),
    ("cluster_size", "same-group cluster size (meeting)"),
)


def plot_journeys(journeys, path, title: str = "") -> Path:
    """What researchers read off a run with routes (``crowdmotion.journeys.Journeys``):
    each queue's length every second, and the persons who have left by each exit over
    time (the N-t curve whose slope is the exit's flow). A run whose routes hold no queue
    gets the exits alone."""
    queues = {q.stage.name: q.report()["length_per_s"] for q in journeys.queues}
    exits = {name: np.sort(np.asarray(t, dtype=float)) for name, t in journeys.exits.items()}
    fig, axes = plt.subplots(1, 2 if queues else 1, figsize=(11 if queues else 5.8, 3.8), layout="constrained",
                             squeeze=False)
    if queues:
        left = axes[0, 0]
        for name, lengths in queues.items():
            left.step(np.arange(len(lengths)), lengths, where="post", label=name)
        left.set_xlabel("t (s)")
        left.set_ylabel("persons in line")
        left.set_title("queues", fontsize=10)
        left.legend(fontsize=8)
    right = axes[0, -1]
    for name, t in exits.items():
        right.step(np.r_[0.0, t], np.arange(len(t) + 1), where="post", label=f"{name} ({len(t)})")
    right.set_xlabel("t (s)")
    right.set_ylabel("persons left")
    right.set_title("exits" if exits else "exits: nobody left by a route's exit", fontsize=10)
    if exits:
        right.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def plot_group_report(rows: dict, path, title: str = "", panels=REPORT_PANELS) -> Path:
    """Bar charts of per-group measures (``metrics.group_report`` rows, or their means).

    ``rows`` maps a group label to a dict of measures; a value may be a number or a
    ``(mean, error)`` pair (a standard deviation or a confidence half-width), drawn with
    an error bar.
    """
    labels = list(rows)
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.4))
    axes = np.atleast_1d(axes)
    colours = ["tab:blue" if lab.endswith("+") else "tab:orange" if lab.endswith("-") else "tab:gray"
               for lab in labels]
    for ax, (key, name) in zip(axes, panels):
        vals = [rows[lab].get(key) for lab in labels]
        mean = [np.nan if v is None else (v[0] if isinstance(v, (tuple, list)) else v) for v in vals]
        err = [0.0 if v is None or not isinstance(v, (tuple, list)) else v[1] for v in vals]
        ax.bar(range(len(labels)), mean, yerr=err, color=colours, capsize=3)
        ax.set_xticks(range(len(labels)), labels, rotation=0, fontsize=8)
        ax.set_title(name, fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_formation_snapshots(scene: Scene, snapshots: list[dict], path, title: str = "", window=None) -> Path:
    """Panels of formation meshes at chosen moments (as the paper's Figs. 6–8).

    Each snapshot is ``{"time": t, "label": str, "groups": [{"vertices": (n, 2),
    "edges": (m, 2), "torn": (m,), "agents": (n, 2), "radius": float,
    "dislocated": (n,) bool}, ...]}``: mesh edges (torn ones red, dashed), agents as
    discs (dislocated ones black), obstacles where they are at that time.
    ``window`` = (lower, upper) crops every panel (default: the scene's bounds).
    """
    k = len(snapshots)
    lo, hi = (scene.lower, scene.upper) if window is None else (np.asarray(window[0]), np.asarray(window[1]))
    aspect = (hi[1] - lo[1]) / (hi[0] - lo[0])
    wide = aspect < 0.4  # a road: one panel under the other, as wide as the page
    cols = 1 if wide or k == 1 else 2
    rows = (k + cols - 1) // cols
    width = 12.0 if wide else 6.5 * cols
    # a panel's data area is its column less the y label and ticks (about 0.9 in); its height
    # that times the aspect plus the title and x label (0.9 in): no bands of white between rows
    panel = (width / cols - 0.9) * aspect + 0.9
    fig, axes = plt.subplots(rows, cols, figsize=(width + 1.6 * wide, rows * panel + 0.5 * bool(title)),
                             squeeze=False, layout="constrained")
    colours = _snapshot_colours(snapshots)
    for ax, snap in zip(axes.ravel(), snapshots):
        _draw_obstacles_2d(ax, scene, snap["time"], at_t=True)
        for gi, g in enumerate(snap["groups"]):
            c = colours[g.get("name", gi)]
            _draw_mesh(ax, g["vertices"], g["edges"], g["torn"], c, lw=0.6, alpha=0.7)
            body = np.where(g["dislocated"][:, None], np.array([to_rgba("k")]), np.array([to_rgba(c)]))
            ax.add_collection(EllipseCollection(2 * g["radius"], 2 * g["radius"], 0.0, units="xy",
                                                offsets=g["agents"][:, :2], offset_transform=ax.transData,
                                                facecolors=body, edgecolors=body, zorder=4), autolim=False)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{snap.get('label', '')} t = {snap['time']:.1f} s", fontsize=10)
    for ax in axes.ravel()[k:]:
        ax.axis("off")
    legend_outside(axes.ravel()[min(k, cols) - 1], _mesh_handles(colours))
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _snapshot_colours(snapshots: list[dict]) -> dict:
    """Group colours for formation snapshots, by group name where given (else index),
    in the order the groups first appear (a group entering later is in none of the
    first snapshots)."""
    keys: dict = {}
    for snap in snapshots:
        for gi, g in enumerate(snap["groups"]):
            keys.setdefault(g.get("name", gi), None)
    return group_colours(list(keys))


def _mesh_handles(colours: dict) -> list:
    """Legend entries for formation pictures: groups, dislocated agents, torn edges."""
    return ([patches.Patch(color=c, label=str(n)) for n, c in colours.items()]
            + [Line2D([], [], marker="o", ls="", color="k", label="dislocated agent"),
               Line2D([], [], color="red", ls="--", label="torn edge")])


def animate_formation_snapshots(scene: Scene, snapshots: list[dict], path, fps: float = 10.0, title: str = "",
                                window=None) -> Path:
    """An animated GIF of formation meshes and agents, one frame per snapshot (same
    dictionaries as :func:`plot_formation_snapshots`); written atomically."""
    lo, hi = (scene.lower, scene.upper) if window is None else (np.asarray(window[0]), np.asarray(window[1]))
    aspect = (hi[1] - lo[1]) / (hi[0] - lo[0])
    width = 8.0 if aspect > 0.4 else 12.0  # wide scenes (a road) get a wider picture
    # fixed margins in inches round a data area of the scene's aspect (constrained layout
    # with an equal-aspect axes clipped the y label and the legend)
    left, right, bottom, top = 0.75, 1.9, 0.55, 0.35
    height = max(2.0, width * aspect)
    fig = plt.figure(figsize=(left + width + right, bottom + height + top), dpi=72)
    size = fig.get_size_inches()
    ax = fig.add_axes((left / size[0], bottom / size[1], width / size[0], height / size[1]))
    group_colour = _snapshot_colours(snapshots)

    # axes, labels, legend and resting obstacles are drawn once; each frame restores that
    # background and draws only what moves (blitting: about 4x faster than redrawing)
    _draw_obstacles_2d(ax, scene, moving=False)
    movers = _draw_obstacles_2d(ax, scene, moving=True, animated=True, at_t=True)  # their paths go in the background
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    legend_outside(ax, _mesh_handles(group_colour))
    ax.set_title(title, loc="left", fontsize=10)  # drawn once; only the clock is drawn per frame
    label = ax.set_title("t = 0.0 s", loc="right", fontsize=10)
    label.set_animated(True)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    # each group's meshes and agents are three artists made once and refilled per frame
    # (making a scatter and two line artists per group and frame took half the time)
    artists: dict = {}
    images = []
    palette = None
    for snap in snapshots:
        drawn = move_obstacles(ax, movers, snap["time"])
        for gi, g in enumerate(snap["groups"]):
            key = g.get("name", gi)
            if key not in artists:
                artists[key] = _mesh_artists(ax, group_colour[key], lw=0.5, alpha=0.6)
            intact, torn, dots = artists[key]
            segments = g["vertices"][g["edges"]][:, :, :2]
            intact.set_data(*polyline_xy(segments[~g["torn"]]))
            torn.set_data(*polyline_xy(segments[g["torn"]]))
            dots.set_offsets(g["agents"][:, :2])
            dots.set_facecolor(np.where(g["dislocated"][:, None], np.array([[0.0, 0.0, 0.0, 1.0]]),
                                        np.array([to_rgba(group_colour[key])])))
            drawn += [intact, torn, dots]
        label.set_text(f"t = {snap['time']:.1f} s")
        pixels = blit_frame(fig, ax, background, drawn, [label])
        if palette is None:
            palette = gif_palette(pixels, group_colour.values())
        images.append(gif_image(pixels, palette))
    plt.close(fig)
    path = Path(path)
    with atomic_path(path) as tmp:
        write_gif(images, tmp, fps)
    return path


def plot_potential_field(scene: Scene, strength: np.ndarray, vectors: np.ndarray, cell: float, path,
                         title: str = "", arrows: int = 40) -> Path:
    """The obstacle potential field of eq. (2): magnitude f as a heat map (cells of
    ``cell`` metres from the scene's lower corner), its summed direction as arrows."""
    nx, ny = strength.shape
    lo = scene.lower[:2]
    extent = (lo[0], lo[0] + nx * cell, lo[1], lo[1] + ny * cell)
    fig, ax = plt.subplots(figsize=(8, 8 * ny / nx + 0.8))
    im = ax.imshow(np.ma.masked_equal(strength.T, 0.0), origin="lower", extent=extent, cmap="magma_r", vmin=0, vmax=1,
                   interpolation="nearest")
    _draw_obstacles_2d(ax, scene)
    step = max(1, int(max(nx, ny) / arrows))
    ii, jj = np.meshgrid(np.arange(0, nx, step), np.arange(0, ny, step), indexing="ij")
    v = vectors[ii, jj]
    keep = np.linalg.norm(v, axis=-1) > 0
    x = lo[0] + (ii + 0.5) * cell
    y = lo[1] + (jj + 0.5) * cell
    ax.quiver(x[keep], y[keep], v[keep][:, 0], v[keep][:, 1], color="teal", scale=arrows, width=0.002, zorder=3)
    fig.colorbar(im, ax=ax, label="field magnitude f = 1 − d/r", shrink=0.8)
    ax.set_xlim(scene.lower[0], scene.upper[0])
    ax.set_ylim(scene.lower[1], scene.upper[1])
    ax.set_aspect("equal")
    ax.set_title(title or "obstacle potential field, eq. (2)")
    return _save(fig, path)
