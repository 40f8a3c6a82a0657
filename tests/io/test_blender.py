"""Blender imports our USD. Runs where a Python with the ``bpy`` package is
named by CROWDMOTION_BLENDER_PYTHON (bpy pins its own numpy, so it lives in a venv of its
own: ``python3.11 -m venv bpyenv && bpyenv/bin/pip install bpy``); skipped elsewhere."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import Trajectories

BLENDER_PYTHON = os.environ.get("CROWDMOTION_BLENDER_PYTHON")
pytestmark = pytest.mark.skipif(not BLENDER_PYTHON, reason="set CROWDMOTION_BLENDER_PYTHON to a Python with bpy")


def test_blender_puts_agents_and_obstacles_where_the_trajectories_say(tmp_path):
    scene = cm.Scene(bounds=([0, 0], [30, 10]), obstacles=[cm.Box([10, 6], [14, 9]), cm.Circle([20, 2], 1.0)])
    t = np.arange(0, 41) * 0.25  # a 4 fps run, as RVO's default step gives
    pos = np.stack([np.stack([1 + 0.9 * t, np.full_like(t, 2.0 + k)], axis=1) for k in range(3)], axis=1)
    tr = Trajectories(pos, 0.25, radius=[0.25] * 3, metadata={"scene": scene.to_dict()})
    path = tr.save(tmp_path / "run.usdc")
    times = [0.0, 5.0, 10.0]
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_check.py")), str(path),
                           *map(str, times)], capture_output=True, text=True, timeout=300)
    line = next(x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON "))
    got = json.loads(line.split(" ", 1)[1])
    assert got["fps"] == 24.0 and got["frame_end"] == 240  # the file's rate and length
    for frame, time in zip(got["frames"], times):
        f = int(round(time / tr.dt))
        blender = np.array(frame["instances"])[:, :2]  # Blender is Z-up: (x, y) as ours
        np.testing.assert_allclose(np.sort(blender, axis=0), np.sort(tr.positions[f], axis=0), atol=1e-4)
    lo = {k: np.min(v, axis=0) for k, v in got["obstacles"].items()}
    hi = {k: np.max(v, axis=0) for k, v in got["obstacles"].items()}
    np.testing.assert_allclose(np.r_[lo["obstacle_0"], hi["obstacle_0"]], [10, 6, 0, 14, 9, 2], atol=1e-4)
    np.testing.assert_allclose(np.r_[lo["obstacle_1"][:2], hi["obstacle_1"][:2]], [19, 1, 21, 3], atol=0.06)  # a tessellated cylinder


def test_a_blender_character_stands_upright_facing_its_way_by_both_routes_and_the_saved_file_reopens(tmp_path):
    from crowdmotion.cli import _at_fps

    t = np.arange(0, 49) * 0.25
    pos = np.zeros((49, 3, 2))
    pos[:, 0] = np.stack([1 + 0.9 * t, np.full_like(t, 2.0)], axis=1)  # east
    pos[:, 1] = np.stack([np.full_like(t, 5.0), 2 + 1.2 * t], axis=1)  # north
    pos[:, 2] = np.stack([10 + 3 * np.cos(t / 3), 10 + 3 * np.sin(t / 3)], axis=1)  # round a circle
    tr = _at_fps(Trajectories(pos, 0.25, radius=[0.25] * 3), 24.0)  # as `export --to usd` writes it
    path = tr.save(tmp_path / "run.usdc")  # the default prototype axes: Z up, facing -Y
    times = [0.0, 5.0, 10.0]
    (tmp_path / "blend").mkdir()  # the .blend is saved in another folder than the .usdc
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_character.py")), str(path),
                           str(tmp_path / "blend"), *map(str, times)], capture_output=True, text=True, timeout=300)
    line = next(x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON "))
    got = json.loads(line.split(" ", 1)[1])
    assert "Agents" not in got["objects"]  # the guide points are not imported, so never rendered, by default
    for route in ("instancer", "on_points", "reopened"):
        for frame in got[route]:
            f = int(round(frame["t"] / tr.dt))
            inst = frame["instances"]
            assert len(inst) == 3, route
            roots = np.array([i["root"] for i in inst])
            order = [int(np.argmin(np.linalg.norm(roots[:, :2] - p, axis=1))) for p in tr.positions[f]]
            np.testing.assert_allclose(roots[order, :2], tr.positions[f], atol=0.01)  # where the trajectories say
            np.testing.assert_allclose(roots[order, 2], 0.0, atol=0.01)  # feet on the ground
            up = np.array([inst[k]["up"] for k in order])
            assert np.degrees(np.arccos(np.clip(up[:, 2], -1, 1))).max() < 1.0, route  # upright
            forward = np.array([inst[k]["forward"] for k in order])
            yaw = np.arctan2(forward[:, 1], forward[:, 0])
            off = np.degrees(np.abs(np.angle(np.exp(1j * (yaw - tr.facing[f])))))
            assert off.max() < 2.0, (route, off)  # facing its way
