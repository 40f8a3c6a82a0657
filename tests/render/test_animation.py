"""Animations and density maps from Trajectories alone."""

import imageio.v2 as iio
import imageio_ffmpeg
import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.render.animation import animate, plot_density
from crowdmotion.scene import Circle, Scene


def _run():
    t = np.arange(30) * 0.2
    pos = np.stack([np.stack([1 + t, 2 + 0.5 * k + 0 * t], axis=1) for k in range(4)], axis=1)
    act = np.ones((30, 4), bool)
    act[20:, 3] = False
    scene = Scene(((0, 0), (10, 5)), [Circle((5, 4.5), 0.4, path=([0.0, 6.0], [(5, 4.5), (5, 0.5)]))])
    return Trajectories(pos, 0.2, radius=[0.2] * 4, active=act, metadata={"scene": scene.to_dict(), "scenario": "t"})


@pytest.mark.parametrize("suffix", ["mp4", "gif"])
def test_animation_plays_the_run_in_real_time_at_24_fps_and_the_frames_change(tmp_path, suffix):
    # 30 steps of 0.2 s (a 5 fps run, as RVO and MDP runs are): 5.8 s at 24 fps
    path = animate(_run(), tmp_path / f"a.{suffix}", width_px=320, progress=False)
    if suffix == "mp4":
        reader = imageio_ffmpeg.read_frames(str(path))
        meta = next(reader)
        assert meta["fps"] == 24
        w, h = meta["size"]
        frames = [np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in reader]
    else:
        frames = list(iio.mimread(path))
    assert len(frames) == int(5.8 * 24) + 1
    first, last = np.asarray(frames[0], float), np.asarray(frames[-1], float)
    assert np.abs(first - last).mean() > 1.0  # agents (and the moving obstacle) have moved
    assert [p.name for p in tmp_path.iterdir()] == [f"a.{suffix}"]  # no temporary file left


def test_a_long_run_is_shown_faster_in_at_most_max_frames(tmp_path):
    path = animate(_run(), tmp_path / "a.gif", width_px=320, max_frames=40, progress=False)
    assert len(iio.mimread(path)) == 40


def test_density_map_and_bad_suffix(tmp_path):
    assert plot_density(_run(), tmp_path / "d.png", cell=0.5).stat().st_size > 5000
    with pytest.raises(ValueError, match=r"\.mp4 or \.gif"):
        animate(_run(), tmp_path / "a.avi", progress=False)


def test_3d_runs_are_drawn_from_above(tmp_path):
    from crowdmotion.scene import Box, Sphere

    scene = Scene(((0, 0, 0), (10, 10, 10)), [Box((4, 4, 0), (5, 6, 3)), Sphere((7, 7, 5), 1.0)])
    t = np.arange(10) * 0.5
    pos = np.stack([np.stack([1 + t, 1 + 0.5 * t, 2 + 0.1 * t], axis=1)], axis=1)
    traj = Trajectories(pos, 0.5, radius=[0.3], metadata={"scene": scene.to_dict()})
    assert animate(traj, tmp_path / "a.gif", width_px=300, progress=False).stat().st_size > 1000
    assert plot_density(traj, tmp_path / "d.png").stat().st_size > 1000


@pytest.mark.parametrize("moving", [True, False])
def test_blitted_frames_equal_full_redraws(moving):
    from crowdmotion.render.animation import frame_images
    from crowdmotion.scene import Box

    run = _run()
    if not moving:
        run.metadata["scene"] = Scene(((0, 0), (10, 5)), [Circle((5, 4.5), 0.4), Box((7, 1), (8, 2))]).to_dict()
    frames = [0, 7, 19, 20, 29]
    fast = list(frame_images(run, frames, width_px=320))
    full = list(frame_images(run, frames, width_px=320, blit=False))
    for a, b in zip(fast, full):
        np.testing.assert_array_equal(a, b)
