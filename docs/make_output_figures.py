"""Make the pictures of docs/getting-started.md: a frame of `crowdmotion render`'s video,
its density map, and the `crowdmotion view` player in headless Chromium (if installed).

    python docs/make_output_figures.py
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from PIL import Image

from crowdmotion.cli import builtin_scenarios
from crowdmotion.render.animation import animate, plot_density
from crowdmotion.render.player import write_player
from crowdmotion.scenario import load_scenario, run_scenario

IMG = Path(__file__).parent / "img"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def main() -> None:
    scenes = {p.stem: p for p in builtin_scenarios()}
    traj = run_scenario(load_scenario(scenes["rvo_doorway"]), progress=False).trajectories
    with tempfile.TemporaryDirectory() as tmp:
        gif = animate(traj, Path(tmp) / "a.gif", max_frames=40, width_px=800, progress=False)
        im = Image.open(gif)
        im.seek(25)
        im.convert("RGB").save(IMG / "output_animation_frame.png")
        page = write_player(traj, Path(tmp) / "view.html")
        chromium = shutil.which("chromium") or shutil.which("chromium-browser")
        if chromium:
            subprocess.run([chromium, *FLAGS, f"--user-data-dir={tmp}/profile", "--window-size=1000,520",
                            f"--screenshot={IMG / 'output_player.png'}", f"file://{page}"], check=True,
                           capture_output=True, timeout=120)
    plot_density(traj, IMG / "output_density.png", cell=0.5)  # as `crowdmotion render` draws it
    print("wrote", *sorted(p.name for p in IMG.glob("output_*.png")))


if __name__ == "__main__":
    main()
