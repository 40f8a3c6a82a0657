"""docs/blender_addon.png and docs/blender_by_hand.png: rvo_street_O at its default
settings, exported as `crowdmotion export --to usd` writes it, imported into Blender (the
``bpy`` package) and rendered with Cycles: with the crowdmotion add-on (walking
characters), and by hand (Blender's USD importer, the prototypes given a character's
mesh by docs/blender_by_hand.py: placed and turned, not walking).

    python docs/make_blender_figures.py --python /path/to/venv-with-bpy/bin/python [--time 18 --focus 30,7,6]

The frame is drawn by tests/io/blender_addon_check.py (``--render``: a floor, a sun, a
camera framing the characters, 8 samples, no denoising), at ``--size`` pixels, saved
with a palette of 256 colours.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
CHECK = HERE.parent / "tests" / "io" / "blender_addon_check.py"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--python", required=True, help="a Python with the bpy package")
    ap.add_argument("--scene", default="rvo_street_O")
    ap.add_argument("--time", type=float, default=18.0, help="seconds into the run")
    ap.add_argument("--focus", default="30,7,6", help="X,Y,R: frame the characters within R m of (X, Y)")
    ap.add_argument("--size", default="640,250")
    ap.add_argument("-o", "--output", default=str(HERE / "blender_addon.png"))
    ap.add_argument("--by-hand", default=str(HERE / "blender_by_hand.png"), help="the by-hand route's picture")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    from crowdmotion.blender import write_addon
    from crowdmotion.builtin import builtin_scenarios
    from crowdmotion.cli import main as cli
    from crowdmotion.scenario import load_scenario, run_scenario

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = {p.stem: p for p in builtin_scenarios()}[args.scene]
        run_scenario(load_scenario(path), progress=False).trajectories.save(tmp / "trajectories.parquet")
        cli(["export", str(tmp / "trajectories.parquet"), "--to", "usd"])
        addon = write_addon(tmp)
        (tmp / "user").mkdir()
        cmd = [args.python, str(CHECK), str(addon), str(tmp / "trajectories.usdc"), str(tmp),
               "--times", str(args.time), "--render", "--size", args.size]
        if args.focus:
            cmd += ["--focus", args.focus]
        done = subprocess.run(cmd, capture_output=True, text=True,
                              env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp / "user")})
        line = next((x for x in done.stdout.splitlines() if x.startswith("CROWDMOTION_JSON ")), None)
        if line is None:
            sys.exit(done.stderr[-3000:])
        got = json.loads(line.split(" ", 1)[1])
        from PIL import Image  # a palette of 256 colours: a third of the file

        def save(png: Path, dest: str) -> None:
            Image.open(png).convert("RGB").quantize(256, Image.Quantize.MEDIANCUT).save(dest, optimize=True)

        save(tmp / "crowd.png", args.output)
        done = subprocess.run([args.python, str(HERE / "blender_by_hand.py"), str(tmp / "trajectories.usdc"),
                               str(tmp / "by_hand.png"), str(args.time), args.focus, args.size],
                              capture_output=True, text=True)
        if "CROWDMOTION_DONE" not in done.stdout:
            sys.exit(done.stderr[-3000:])
        save(tmp / "by_hand.png", args.by_hand)
    frame = got["frames"][-1]["rigs"]
    print(f"{args.by_hand}: the same frame by hand")
    print(f"{args.output}: {sum(r['visible'] for r in frame)} characters in the scene at t = {args.time} s, Blender "
          f"{got['version']}, rendered in {got['render']['render_s']:.1f} s")


if __name__ == "__main__":
    main()
