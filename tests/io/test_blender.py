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


def test_an_obstacle_dropped_in_during_a_live_run_shows_in_blender_only_while_it_stood(tmp_path):
    from crowdmotion import blender
    from tests.io.readers import door_session

    traj, door = door_session()  # the door stands from 1 to 2 s: frames 24-47 of the 24 fps stage
    path = traj.save(tmp_path / "live.usdc")
    frames = [0, 23, 24, 47, 48, 60]
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_visibility_check.py")),
                           str(pathlib.Path(blender.__file__).parent), str(path), *map(str, frames)],
                          capture_output=True, text=True, timeout=300, env={**os.environ, "HOME": str(tmp_path)})
    line = next(x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON "))
    got = json.loads(line.split(" ", 1)[1])
    assert [got[str(f)][f"obstacle_{door}"] for f in frames] == [False, False, True, True, False, False]
    assert all(got[str(f)]["obstacle_0"] for f in frames), "the wall that always stood always shows"


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


def _contact_spells(contact: np.ndarray):
    """(agent, first frame, end frame) of each spell a foot is down."""
    for i in range(contact.shape[1]):
        edges = np.flatnonzero(np.diff(np.r_[0, contact[:, i].astype(np.int8), 0]))
        yield from ((i, a, b) for a, b in zip(edges[::2], edges[1::2]))


def foot_slide(feet: np.ndarray, loco) -> np.ndarray:
    """Per contact spell of either foot (crowdmotion's contacts): how far, in metres, the
    posed ankle moves on the ground from where it was at the spell's first frame."""
    out = []
    for side, contact in enumerate((loco.contact_left, loco.contact_right)):
        for i, a, b in _contact_spells(np.asarray(contact)[: len(feet)]):
            p = feet[a:b, i, side, :2]
            out.append(np.linalg.norm(p - p[0], axis=1).max())
    return np.array(out)


@pytest.mark.slow
def test_the_addon_walks_each_character_at_its_own_pace_where_the_trajectories_say(tmp_path):
    from crowdmotion.blender import write_addon
    from crowdmotion.io import read_locomotion

    fps = 30.0  # not Blender's default 24: the add-on sets the scene's rate from the file
    t = np.arange(0, 301) / fps
    pos = np.zeros((301, 4, 2))
    pos[:, 0] = np.stack([1 + 0.8 * t, np.full_like(t, 2.0)], axis=1)  # slow, east
    pos[:, 1] = np.stack([np.full_like(t, 6.0), 1 + 1.6 * t], axis=1)  # brisk, north
    pos[:, 2] = [9.0, 4.0]  # stands
    arc = np.minimum(t, 6.0)  # round a circle, then stops
    pos[:, 3] = np.stack([4 + 3 * np.cos(arc / 3), 8 + 3 * np.sin(arc / 3)], axis=1)
    tr = Trajectories(pos, 1 / fps, radius=[0.25] * 4, group=["a", "a", "b", "c"])
    path = tr.save(tmp_path / "run.usdc")
    loco = read_locomotion(path)
    addon = write_addon(tmp_path)
    (tmp_path / "user").mkdir()
    times = [0.5, 5.0, 9.5]
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_addon_check.py")),
                           str(addon), str(path), str(tmp_path), "--times", ",".join(map(str, times)),
                           "--feet", f"0:{tr.n_frames}", "--render"],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")})
    line = next((x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON ")), None)
    assert line, done.stderr[-3000:]
    got = json.loads(line.split(" ", 1)[1])
    assert got["result"] == ["FINISHED"] and got["agents"] == 4
    assert got["fps"] == fps and got["frame_start"] == 0 and got["frame_end"] == tr.n_frames - 1
    for frame in got["frames"]:
        f = int(round(frame["t"] * fps))
        rigs = frame["rigs"]
        roots = np.array([r["root"] for r in rigs])
        np.testing.assert_allclose(roots[:, :2], tr.positions[f], atol=0.01)  # where the trajectories say
        np.testing.assert_allclose(roots[:, 2], 0.0, atol=0.01)  # on the ground
        up = np.array([r["up"] for r in rigs])
        assert np.degrees(np.arccos(np.clip(up[:, 2], -1, 1))).max() < 1.0  # upright
        fwd = np.array([r["forward"] for r in rigs])
        off = np.degrees(np.abs(np.angle(np.exp(1j * (np.arctan2(fwd[:, 1], fwd[:, 0]) - tr.facing[f])))))
        assert off.max() < 2.0, off  # facing its way
        assert rigs[2]["idle"] and not rigs[0]["idle"] and not rigs[1]["idle"]  # the standing one stands
    assert got["frames"][-1]["rigs"][3]["idle"]  # the one that stopped stands too

    feet = np.load(tmp_path / "feet.npy").astype(float)
    # cycles played: left heel strikes (the ankle coming down to the ground) per second
    low = feet[:, :, 0, 2] < 0.095
    strikes = (low[1:] & ~low[:-1]).sum(axis=0) / (tr.n_frames / fps)
    wraps = (np.diff(loco.gait_phase, axis=0) < -0.5).sum(axis=0) / (tr.n_frames / fps)  # the phase's own rate
    assert strikes[1] > 1.25 * strikes[0] > 0, strikes  # the brisk one steps faster
    np.testing.assert_allclose(strikes[:2], wraps[:2], atol=0.15)
    assert np.ptp(feet[:, 2, :, :2], axis=0).max() < 1e-4  # the standing one does not shuffle

    slide = foot_slide(feet, loco) * 100
    straight = foot_slide(feet[:, :2], type(loco)(**{k: (getattr(loco, k)[:, :2] if k.startswith("contact") else
                                                         getattr(loco, k)) for k in ("distance", "gait_phase",
                                                         "gait_state", "turn_rate", "contact_left", "contact_right",
                                                         "kind", "params")})) * 100
    print(f"foot slide per contact (cm), all four: median {np.median(slide):.2f}, p95 {np.percentile(slide, 95):.2f}, "
          f"max {slide.max():.2f} over {slide.size} contacts; the two straight walkers: median "
          f"{np.median(straight):.2f}, p95 {np.percentile(straight, 95):.2f}; stage times (s): {got['times']}")
    assert np.percentile(straight, 95) <= 1.0  # a planted foot stays put on a straight path
    # on the circle the body turns over a planted foot a hip's width (0.1 m) to the side: 0.1 m x the
    # turn of a stance (1/3 rad/s x 0.7 s) is the most it may slide, plus that 1 cm
    assert np.percentile(slide, 95) <= 0.1 * (1 / 3) * 0.75 * 100 + 1.0

    import imageio.v3 as iio

    crowd, empty = (iio.imread(tmp_path / f"{n}.png").astype(float)[..., :3] for n in ("crowd", "empty"))
    h, w = crowd.shape[:2]
    for x0, y0, x1, y1 in got["render"]["boxes"]:  # camera-view boxes, y up from the bottom
        box = (slice(int((1 - y1) * h), int(np.ceil((1 - y0) * h))), slice(int(x0 * w), int(np.ceil(x1 * w))))
        assert np.abs(crowd[box] - empty[box]).max() > 30, (x0, y0)  # each character is drawn
    assert got["render"]["pointclouds"] == []  # no guide spheres


def test_a_character_shows_only_while_its_agent_is_in_the_scene(tmp_path):
    # an agent that has left (or not yet come) hides its body too, not its armature alone:
    # a child mesh does not inherit its parent's hiding, and every body stood on at its goal
    from crowdmotion.blender import write_addon

    fps = 24.0
    pos = np.zeros((97, 2, 2))
    pos[:, 0] = np.stack([1 + np.arange(97) / fps, np.full(97, 2.0)], axis=1)
    pos[:, 1] = [5.0, 5.0]
    active = np.ones((97, 2), bool)
    active[48:, 0] = False  # leaves at 2 s
    active[:24, 1] = False  # comes at 1 s
    path = Trajectories(pos, 1 / fps, radius=[0.25] * 2, active=active).save(tmp_path / "run.usdc")
    addon = write_addon(tmp_path)
    (tmp_path / "user").mkdir()
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_addon_check.py")),
                           str(addon), str(path), str(tmp_path), "--times", "0.5,1.5,3.0"],
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")})
    line = next((x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON ")), None)
    assert line, done.stderr[-3000:]
    shown = [[r["visible"] and all(r["body_visible"]) for r in f["rigs"]] for f in json.loads(line.split(" ", 1)[1])["frames"]]
    hidden = [[not r["visible"] and not any(r["body_visible"]) for r in f["rigs"]]
              for f in json.loads(line.split(" ", 1)[1])["frames"]]
    assert [s[0] for s in shown] == [True, True, False] and hidden[2][0]  # gone after 2 s, body and all
    assert [s[1] for s in shown] == [False, True, True] and hidden[0][1]  # there from 1 s


@pytest.mark.slow
@pytest.mark.parametrize("name", ["rvo_street_O", "formation_army"])
def test_walkers_of_a_builtin_scene_do_not_slide_their_feet(name, tmp_path):
    """Foot slide per contact p95 ≤ 3 cm on the built-in scene at its default settings,
    exported as `crowdmotion export --to usd` writes it and imported with the add-on."""
    from crowdmotion.blender import write_addon
    from crowdmotion.cli import builtin_scenarios
    from crowdmotion.cli import main as cli
    from crowdmotion.io import read_locomotion
    from crowdmotion.scenario import load_scenario, run_scenario

    path = {p.stem: p for p in builtin_scenarios()}[name]
    run_scenario(load_scenario(path), progress=False).trajectories.save(tmp_path / "trajectories.parquet")
    assert cli(["export", str(tmp_path / "trajectories.parquet"), "--to", "usd"]) in (0, None)
    usd = tmp_path / "trajectories.usdc"
    loco = read_locomotion(usd)
    addon = write_addon(tmp_path)
    (tmp_path / "user").mkdir()
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_addon_check.py")),
                           str(addon), str(usd), str(tmp_path), "--feet", f"0:{loco.gait_phase.shape[0]}"],
                          capture_output=True, text=True, timeout=900,
                          env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")})
    assert any(x.startswith("CROWDMOTION_JSON ") for x in done.stdout.splitlines()), done.stderr[-3000:]
    slide = foot_slide(np.load(tmp_path / "feet.npy").astype(float), loco) * 100
    print(f"{name}: foot slide per contact (cm) median {np.median(slide):.2f}, p95 {np.percentile(slide, 95):.2f}, "
          f"max {slide.max():.2f} over {slide.size} contacts")
    assert slide.size > 1000 and np.percentile(slide, 95) <= 3.0


@pytest.mark.slow
def test_an_own_character_plays_its_walk_cycle_at_each_agents_gait_phase(tmp_path):
    """*Own character*: a tiny armature of one's own with a one-stride walk action, bound by
    the add-on, shows on every walking frame the pose of its cycle at the agent's gait
    phase (so each plays it at its own rate), and its rest pose while it stands."""
    from crowdmotion.blender import write_addon
    from crowdmotion.io import read_locomotion

    fps = 24.0
    t = np.arange(0, 241) / fps
    pos = np.zeros((241, 3, 2))
    pos[:, 0] = np.stack([1 + 0.8 * t, np.full_like(t, 2.0)], axis=1)  # slow, east
    pos[:, 1] = np.stack([np.full_like(t, 6.0), 1 + 1.6 * t], axis=1)  # brisk, north
    pos[:, 2] = [9.0, 4.0]  # stands
    tr = Trajectories(pos, 1 / fps, radius=[0.25] * 3)
    path = tr.save(tmp_path / "run.usdc")
    loco = read_locomotion(path)
    addon = write_addon(tmp_path)
    (tmp_path / "user").mkdir()
    done = subprocess.run([BLENDER_PYTHON, str(pathlib.Path(__file__).with_name("blender_own_rig_check.py")),
                           str(addon), str(path)], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")})
    line = next((x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON ")), None)
    assert line, done.stderr[-3000:]
    got = json.loads(line.split(" ", 1)[1])
    assert got["result"] == ["FINISHED"] and got["agents"] == 3 and got["bodies"] == [1, 1, 1]
    assert got["walk_range"] == [1.0, 25.0]
    roots = np.array([[r["root"] for r in row] for row in got["frames"]])
    thigh = np.array([[r["thigh"] for r in row] for row in got["frames"]])
    assert roots.shape[0] == tr.n_frames
    np.testing.assert_allclose(roots[:, :, :2], tr.positions, atol=0.01)  # where the trajectories say
    # walking (past the 0.3 s fade from standing): the cycle's pose at the agent's phase,
    # to the linear keys' rounding (a key every 1/24 of the stride)
    walking = (loco.gait_state[:, :2] == 1)
    walking[: int(0.5 * fps)] = False
    want = got["amplitude"] * np.sin(2 * np.pi * loco.gait_phase[:, :2])
    assert walking.sum() > 400
    np.testing.assert_allclose(thigh[:, :2][walking], want[walking], atol=0.02)
    # so each plays its cycle at its own rate: cycles per second from the thigh's swings
    swings = ((thigh[1:, :2] >= 0) & (thigh[:-1, :2] < 0)).sum(axis=0) / (tr.n_frames / fps)
    wraps = (np.diff(loco.gait_phase[:, :2], axis=0) < -0.5).sum(axis=0) / (tr.n_frames / fps)
    np.testing.assert_allclose(swings, wraps, atol=0.15)
    assert swings[1] > 1.25 * swings[0] > 0, swings
    assert np.abs(thigh[:, 2]).max() < 1e-6  # the standing one stands in its rest pose
    low = np.array([[r["low"] for r in row] for row in got["frames"]])
    np.testing.assert_allclose(low[:, 2], 0.0, atol=0.01)  # on the ground
