"""Animations (MP4 through imageio-ffmpeg, or GIF) and density maps of any run, from its
Trajectories alone (the scene comes from the trajectories' metadata)."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import patches  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection, LineCollection  # noqa: E402

from crowdmotion.io.atomic import atomic_path  # noqa: E402
from crowdmotion.progress import tracked  # noqa: E402
from crowdmotion.render.plots import (_draw_obstacles_2d, _group_colours, _save, blit_frame, gif_image,  # noqa: E402
                                      gif_palette, write_gif)
from crowdmotion.scene import Scene, scene_of  # noqa: E402
from crowdmotion.trajectories import Trajectories, resample  # noqa: E402

VIDEO_FPS = 24.0  # the rate animators' scenes start at


def video_rate(traj: Trajectories, fps: float | None = None, max_frames: int = 600) -> float:
    """Frames of the run per second of it that a video at ``fps`` (default ``VIDEO_FPS``)
    shows: ``fps``, or fewer for a run longer than ``max_frames`` frames at that rate
    (shown faster than real time)."""
    fps = float(fps) if fps else VIDEO_FPS
    duration = (traj.n_frames - 1) * traj.dt
    return min(fps, (max_frames - 1) / duration) if duration > 0 else fps


def _extent(traj: Trajectories, scene: Scene | None):
    if scene is not None:
        return scene.lower[:2], scene.upper[:2]
    p = traj.positions[..., :2][traj.active_mask]
    return p.min(axis=0) - 1.0, p.max(axis=0) + 1.0


def animate(traj: Trajectories, path, fps: float | None = None, trail_s: float = 2.0, max_frames: int = 600,
            width_px: int = 960, progress: bool = True) -> Path:
    """Write an MP4 (``.mp4``, H.264 through imageio-ffmpeg) or GIF (``.gif``) of the run
    seen from above: obstacles where they are at each moment, agents as discs of their
    radius in their group's colour, a fading trail of the last ``trail_s`` seconds, the
    time. The video plays at ``fps`` (default 24): the run is resampled to that rate by
    straight moves between its frames (an MDP run stepping every 0.85 s moves smoothly,
    in real time); a run longer than ``max_frames`` frames at that rate is shown faster
    than real time (the clock says the run's time). 3D runs are shown from above (x, y)."""
    path = Path(path)
    kind = path.suffix.lower()
    if kind not in (".mp4", ".gif"):
        raise ValueError(f"animations are .mp4 or .gif, got {path.name!r}")
    if traj.n_frames > 1:  # one video frame per 1/fps s of the run, or fewer for a long run
        traj = resample(traj, video_rate(traj, fps, max_frames), "linear")
    fps = float(fps) if fps else VIDEO_FPS
    frames = np.arange(min(traj.n_frames, max_frames))
    images = frame_images(traj, frames, trail_s, width_px)
    first = next(images)
    h_px, w_px = first.shape[:2]
    with atomic_path(path) as tmp:
        if kind == ".mp4":
            import imageio_ffmpeg

            sink = imageio_ffmpeg.write_frames(str(tmp), (w_px, h_px), fps=fps, codec="libx264", macro_block_size=16,
                                               pix_fmt_out="yuv420p", output_params=["-f", "mp4"])
            sink.send(None)
        else:
            gif_frames = []
            palette = gif_palette(first, _group_colours(traj).values())
        rest = tracked(images, "rendering", "frame", total=len(frames) - 1, enabled=progress)
        for rgb in itertools.chain([first], rest):
            if kind == ".mp4":
                sink.send(rgb)
            else:
                gif_frames.append(gif_image(rgb, palette))
        if kind == ".mp4":
            sink.close()
        else:
            write_gif(gif_frames, tmp, fps)
    return path


def frame_images(traj: Trajectories, frames, trail_s: float = 2.0, width_px: int = 960,
                 blit: bool = True) -> Iterator[np.ndarray]:
    """The animation's frames as (H, W, 3) uint8 images, one per index in ``frames``.

    With ``blit`` (the default) the axes, ticks and static obstacles are drawn once and
    each frame redraws only the agents, trails, moving obstacles and clock on top of that
    background, as matplotlib's blitting does; ``blit=False`` redraws the whole figure.
    """
    scene = scene_of(traj)
    lo, hi = _extent(traj, scene)
    aspect = float((hi[1] - lo[1]) / (hi[0] - lo[0]))
    dpi = 100
    w_in = width_px / dpi
    h_in = max(2.0, w_in * aspect) + 0.4
    h_in = round(h_in * dpi / 16) * 16 / dpi  # even pixel sizes for H.264
    fig, ax = plt.subplots(figsize=(w_in, h_in), dpi=dpi)
    try:
        colours = _group_colours(traj)
        face = np.array([colours[g] for g in traj.group])
        act = traj.active_mask
        pos = traj.positions[..., :2]
        trail_n = max(1, int(round(trail_s / traj.dt)))
        title = f"{traj.metadata.get('scenario', traj.metadata.get('method', ''))}"
        if traj.dim == 3:
            title += " (seen from above)"
        moving = scene is not None and any(ob.is_moving or ob.is_timed for ob in scene.obstacles)
        if scene is not None:
            _draw_obstacles_2d(ax, scene, moving=False)  # the resting ones once, in the background
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.tick_params(labelsize=7)
        fig.subplots_adjust(right=0.86)  # the group legend beside the scene, covering nobody
        fig.legend(handles=[patches.Patch(color=c, label=str(n)) for n, c in colours.items()], loc="center right",
                   fontsize=8, frameon=False)
        trails = LineCollection([], linewidths=1.0, animated=blit)
        ax.add_collection(trails)
        d = 2 * traj.radius
        bodies = EllipseCollection(d, d, np.zeros(traj.n_agents), units="xy", offsets=pos[0],
                                   offset_transform=ax.transData, edgecolors="k", linewidths=0.3, zorder=4,
                                   animated=blit)
        ax.add_collection(bodies)
        label = ax.set_title("", fontsize=10, family="monospace")
        label.set_animated(blit)
        shapes = []
        if blit:
            fig.canvas.draw()
            background = fig.canvas.copy_from_bbox(fig.bbox)
        for f in frames:
            if moving:
                for artist in shapes:
                    artist.remove()
                before = set(ax.patches) | set(ax.lines)
                _draw_obstacles_2d(ax, scene, f * traj.dt, moving=True, at_t=True)
                shapes = [a for a in list(ax.patches) + list(ax.lines) if a not in before]
                for artist in shapes:
                    artist.set_animated(blit)
            a0 = max(0, f - trail_n)
            if f > a0:
                seg = np.stack([pos[a0:f], pos[a0 + 1:f + 1]], axis=2)
                keep = act[a0:f] & act[a0 + 1:f + 1]
                rgba = np.broadcast_to(face, (len(seg),) + face.shape).copy()
                rgba[..., 3] = np.linspace(0.1, 0.6, len(seg))[:, None]
                trails.set_segments(seg[keep])
                trails.set_color(rgba[keep])
            fc = face.copy()
            fc[~act[f], 3] = 0.0
            bodies.set_offsets(pos[f])
            bodies.set_facecolor(fc)
            bodies.set_edgecolor(np.where(act[f][:, None], [[0, 0, 0, 1.0]], [[0, 0, 0, 0.0]]))
            label.set_text(f"{title}  t = {f * traj.dt:6.1f} s")
            if blit:
                rgb = blit_frame(fig, ax, background, [trails, bodies] + shapes, [label])[..., :3]
            else:
                fig.canvas.draw()
                rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3]
            yield np.ascontiguousarray(rgb)
    finally:
        plt.close(fig)


def plot_density(traj: Trajectories, path, cell: float = 0.5, title: str = "") -> Path:
    """Mean density map (agents per m², averaged over the frames) on cells of ``cell``
    metres, seen from above, over the scene's obstacles."""
    scene = scene_of(traj)
    lo, hi = _extent(traj, scene)
    nx, ny = max(1, int(np.ceil((hi[0] - lo[0]) / cell))), max(1, int(np.ceil((hi[1] - lo[1]) / cell)))
    p = traj.positions[..., :2][traj.active_mask]
    counts, _, _ = np.histogram2d(p[:, 0], p[:, 1], bins=[nx, ny], range=[[lo[0], lo[0] + nx * cell],
                                                                          [lo[1], lo[1] + ny * cell]])
    density = counts / traj.n_frames / cell**2
    wide = (hi[1] - lo[1]) / (hi[0] - lo[0]) < 0.6
    # laid out as one: the colour bar the map's own width (below a wide scene) or height,
    # the title over the map (a bar placed apart left a wide gap and a title hanging off it)
    fig, ax = plt.subplots(figsize=(8, 8 * (hi[1] - lo[1]) / (hi[0] - lo[0]) + (1.6 if wide else 0.8)),
                           layout="constrained")
    # one hot cell (a goal where arrivals stand) must not wash out the rest: clip the scale
    # at the 99th percentile of the occupied cells and say so on the bar
    occupied = density[density > 0]
    top = float(np.percentile(occupied, 99)) if occupied.size else 1.0
    clipped = occupied.size and density.max() > top * 1.001
    im = ax.imshow(np.ma.masked_equal(density.T, 0), origin="lower", cmap="viridis", vmin=0, vmax=top,
                   extent=(lo[0], lo[0] + nx * cell, lo[1], lo[1] + ny * cell))
    if scene is not None:
        _draw_obstacles_2d(ax, scene)
    label = "mean density (agents / m²; white: nobody there)" if (density == 0).any() else "mean density (agents / m²)"
    fig.colorbar(im, ax=ax, label=label, shrink=0.9 if wide else 0.8, extend="max" if clipped else "neither",
                 location="bottom" if wide else "right", pad=0.02)
    if not title:
        name = traj.metadata.get("scenario")
        title = (f"{name}: " if name else "") + f"mean density, {cell} m cells" + \
            (", seen from above (heights left out)" if traj.dim == 3 else "")
    if clipped:
        title += f"\n(colour scale clipped at the 99th percentile; densest cell {density.max():.2g} /m²)"
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title, loc="left", fontsize=10)
    return _save(fig, path)
