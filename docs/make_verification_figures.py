"""Make the figures of docs/verification.md and the congestion figure of docs/rvo.md.

    python docs/make_verification_figures.py

Runs the whole verification suite (as `crowdmotion verify` does, a few minutes), keeps
the RVO picture of each case as docs/img/verify_<case>.png (the MDP ones where RVO does not
apply), prints the markdown table, and draws docs/img/rvo_congestion.png: the mean density
of 500 agents rounding the RiMEA 15 corner with the exact distance field and with the
congestion-aware one, and prints RiMEA 15's times over five seeds.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crowdmotion import verify  # noqa: E402
from crowdmotion.render.plots import _draw_obstacles_2d  # noqa: E402

IMG = Path(__file__).parent / "img"


RIMEA_15 = next(c for c in verify.CASES if c.name == "rimea_15_corner_crowd")


def rimea_15_table() -> None:
    print("| seed | short | corner | long | corner between |")
    print("|---|---|---|---|---|")
    for seed in range(5):
        t = {name: verify.rimea_15_last_out(name, verify.simulate("rvo", setup, seed))
             for name, setup in RIMEA_15.build("rvo").items()}
        ok = t["short"] <= t["corner"] <= t["long"]
        print(f"| {seed} | {t['short']:.0f} s | {t['corner']:.0f} s | {t['long']:.0f} s | {'yes' if ok else 'no'} |",
              flush=True)


def congestion_figure() -> None:
    case = RIMEA_15
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.0), layout="constrained")
    for ax, cong in zip(axes, (0.0, 1.0)):
        setup = case.build("rvo")["corner"]
        setup.params = {**setup.params, "congestion": cong}
        r = verify.simulate("rvo", setup)
        pos = r.traj.positions[r.traj.active_mask]
        cell = 0.5
        lo, hi = setup.scene.lower, setup.scene.upper
        bins = [np.arange(lo[0], hi[0] + cell, cell), np.arange(lo[1], hi[1] + cell, cell)]
        h, _, _ = np.histogram2d(pos[:, 0], pos[:, 1], bins=bins)
        dens = np.ma.masked_equal(h / r.traj.n_frames / cell ** 2, 0)
        im = ax.imshow(dens.T, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), cmap="viridis", vmax=2.5)
        _draw_obstacles_2d(ax, setup.scene)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        label = "exact distance field (congestion = 0)" if cong == 0 else f"congestion = {cong:g}"
        ax.set_title(f"{label}: last of 500 out at {verify.rimea_15_last_out('corner', r):.0f} s", fontsize=10)
    fig.colorbar(im, ax=axes, label="mean density (agents / m²)", shrink=0.85)
    fig.suptitle("RiMEA 15 corner, RVO: where 500 agents walk")
    out = IMG / "rvo_congestion.png"
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")


def main() -> None:
    congestion_figure()
    rimea_15_table()
    verdicts = []
    with tempfile.TemporaryDirectory() as tmp:
        for case, method in verify.select():
            v = verify.run_case(case, method, out=Path(tmp))
            verdicts.append(v)
            print(verify.table([v]).splitlines()[-1], flush=True)
        for case in verify.CASES:
            method = "rvo" if "rvo" in case.methods else case.methods[0]
            shutil.copy(Path(tmp) / f"{case.name}_{method}.png", IMG / f"verify_{case.name}.png")
    print()
    print(verify.table(verdicts))


if __name__ == "__main__":
    main()
