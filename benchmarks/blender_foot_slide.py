"""Foot slide of the add-on's walker on a run's USD, per contact and by cause.

Imports each USD file with the add-on into the real ``bpy`` module (through the import
operator, as a user would), reads every character's posed ankles on every frame and, per
contact spell of either foot (crowdmotion's ``contact_left`` / ``contact_right``), takes
the farthest the ankle moves on the ground from where it was at the spell's first frame,
the measurement of tests/io/test_blender.py. Contacts are then told apart by what the
body does during them, the first of these that holds:

``stop/start``  the spell holds a frame that is not walk or run (the idle blend)
``sideways``    the body moves more than 20° off its facing on some frame
``turning``     the facing turns more than 10° over the spell
``speed change`` the path speed changes by more than 15 % over the spell
``steady``      none of these

::

    python benchmarks/blender_foot_slide.py --python /path/to/bpyenv/bin/python run.usdc [more.usdc]

The files are what ``crowdmotion export --to usd`` writes (24 fps by default), e.g. of
``crowdmotion demo --only rvo_street_O formation_army``. ``--python`` is a Python with the
``bpy`` package (default: ``CROWDMOTION_BLENDER_PYTHON``).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from crowdmotion.io import read_locomotion, read_trajectories
from crowdmotion.locomotion import RUN, WALK

from blender_addon_play import run_addon_check  # benchmarks/: the add-on check in bpy, one way

CAUSES = ("stop/start", "sideways", "turning", "speed change", "steady")


def posed_feet(blender_python: str, usd: Path, folder: Path, frames: int) -> tuple[np.ndarray, dict]:
    """(ankles (frames, agents, 2, 3) in Blender's world, the check's JSON)."""
    got = run_addon_check(blender_python, usd, folder, "--feet", f"0:{frames}", timeout=3600)
    return np.load(folder / "feet.npy").astype(float), got


def contacts(feet: np.ndarray, loco, traj) -> tuple[np.ndarray, np.ndarray]:
    """(slide per contact spell in metres, its cause as an index into CAUSES)."""
    pos = traj.positions[: len(feet)]
    vel = np.gradient(pos, traj.dt, axis=0)
    speed = np.linalg.norm(vel, axis=2)
    facing = traj.facing[: len(feet)]
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(vel[..., 1], vel[..., 0]) - facing))))
    off[speed < 0.1] = 0.0  # no direction to be off when hardly moving
    stepping = (loco.gait_state == WALK) | (loco.gait_state == RUN)
    shown = traj.active_mask[: len(feet)]  # a hidden character's pose is no contact (its matrix is stale)
    slide, cause = [], []
    for side, contact in enumerate((loco.contact_left, loco.contact_right)):
        contact = np.asarray(contact)[: len(feet)].astype(bool) & shown
        for i in range(contact.shape[1]):
            edges = np.flatnonzero(np.diff(np.r_[0, contact[:, i].astype(np.int8), 0]))
            for a, b in zip(edges[::2], edges[1::2]):
                if not stepping[a:b, i].any():
                    continue  # standing: both feet down, nothing to slide but the idle pose
                p = feet[a:b, i, side, :2]
                slide.append(np.linalg.norm(p - p[0], axis=1).max())
                turn = abs(np.angle(np.exp(1j * (facing[b - 1, i] - facing[a, i]))))
                v = speed[a:b, i]
                if not stepping[a:b, i].all():
                    c = 0
                elif off[a:b, i].max() > np.radians(20):
                    c = 1
                elif turn > np.radians(10):
                    c = 2
                elif v.max() > 1.15 * max(v.min(), 1e-3):
                    c = 3
                else:
                    c = 4
                cause.append(c)
    return np.array(slide), np.array(cause)


def table(name: str, slide: np.ndarray, cause: np.ndarray) -> list[str]:
    rows = []
    cm = slide * 100
    rows.append(f"| {name} | all | {cm.size} | {np.median(cm):.2f} cm | {np.percentile(cm, 95):.2f} cm | "
                f"{cm.max():.1f} cm |")
    for k, c in enumerate(CAUSES):
        part = cm[cause == k]
        if part.size:
            rows.append(f"| | {c} | {part.size} | {np.median(part):.2f} cm | {np.percentile(part, 95):.2f} cm | "
                        f"{part.max():.1f} cm |")
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("usd", nargs="+", type=Path)
    ap.add_argument("--python", default=os.environ.get("CROWDMOTION_BLENDER_PYTHON"),
                    help="a Python with bpy (default: $CROWDMOTION_BLENDER_PYTHON)")
    ap.add_argument("--save", type=Path, help="folder to keep each file's ankles and contacts in (.npz)")
    args = ap.parse_args(argv)
    if not args.python:
        ap.error("name a Python with bpy: --python or CROWDMOTION_BLENDER_PYTHON")
    print("| file | contacts | count | median | p95 | max |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, usd in enumerate(args.usd):
            traj, loco = read_trajectories(usd), read_locomotion(usd)
            t0 = time.perf_counter()
            feet, got = posed_feet(args.python, usd.resolve(), Path(tmp) / str(k), traj.n_frames)
            slide, cause = contacts(feet, loco, traj)
            if args.save:
                args.save.mkdir(parents=True, exist_ok=True)
                np.savez(args.save / f"{usd.stem}.npz", feet=feet, slide=slide, cause=cause)
            print("\n".join(table(usd.stem, slide, cause)), flush=True)
            print(f"<!-- {usd.name}: import stages {json.dumps({s: round(v, 2) for s, v in got['times'].items()})}, "
                  f"{time.perf_counter() - t0:.0f} s in all -->", flush=True)


if __name__ == "__main__":
    main()
