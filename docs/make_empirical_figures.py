"""The figures of docs/verification.md's comparison with measured crowds.

    python docs/make_empirical_figures.py [--fzj DIR]

Runs crowdmotion's empirical cases (``crowdmotion verify --empirical``: 3 seeds each,
a few minutes on two cores), prints their table and draws:

- docs/img/empirical_speed_density.png: speed against density, Weidmann's curve, the FZJ
  corridor runs, the BOT-360 counterflow runs and crowdmotion's runs of both set-ups;
- docs/img/empirical_bottleneck.png: flow against bottleneck width, the three data series,
  their mean ± 25 % and crowdmotion's flow per seed;
- docs/img/empirical_lanes.png: the lane order against density, with the directions as
  they were and shuffled, and a snapshot of the corridor at b = 1.6 m. With ``--fzj DIR``
  (a folder holding the FZJ data archive's ``bot-360-*.txt`` trajectory files, as
  OpenTraj ships them in ``datasets/HERMES/Corridor-2D``) the measured runs are measured
  by the same code (``empirical.fzj_bot_trajectories``, ``empirical.bot_measures``),
  printed as a table and drawn beside crowdmotion's.

It also prints how the walkers of each counterflow run (and of each measured run) pass
the oncoming stream (``empirical.bot_passing``) and keep their side to the corridor's
end (``empirical.bot_exit_sides``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crowdmotion import empirical, verify  # noqa: E402
from crowdmotion.rvo.density import GAMMA, WEIDMANN_FREE, speed_share, weidmann_speed  # noqa: E402

IMG = Path(__file__).parent / "img"


def run(case_name: str) -> tuple[dict, verify.Verdict]:
    case = next(c for c in empirical.CASES if c.name == case_name)
    outcomes = {name: verify.simulate("rvo", setup) for name, setup in case.build("rvo").items()}
    criterion, measured, passed = case.judge(outcomes)
    o, p = verify._all_clean(outcomes)
    return outcomes, verify.Verdict(case.name, "rvo", criterion, measured, passed and o == 0 and p == 0, o, p, 0.0)


def bot_points(outcomes: dict) -> list[tuple[float, float]]:
    rng = np.random.default_rng(0)
    return [empirical.bot_measures(o.traj, rng)[:2] for o in outcomes.values()]


def fzj_runs(folder: Path) -> dict[str, tuple]:
    """Entrance width (the file's name) -> (trajectories, (density, speed, lane order,
    shuffled)) of each measured BOT-360 run in ``folder``."""
    out = {}
    for path in sorted(folder.glob("bot-360-*.txt")):
        traj = empirical.fzj_bot_trajectories(path)
        out[path.stem] = (traj, empirical.bot_measures(traj, np.random.default_rng(0)))
    if not out:
        raise SystemExit(f"--fzj {folder}: no bot-360-*.txt trajectory files there")
    return out


def print_passing(runs: dict) -> None:
    """How each run's walkers pass the oncoming stream (``empirical.bot_passing``), as a table."""
    print(f"| run | density | meeting an oncoming one (within {empirical.PASS_AHEAD_M:g} m ahead, "
          f"{empirical.PASS_SIDE_M:g} m across) | speed then | speed otherwise | slower than "
          f"{empirical.PASS_STOPPED:g} m/s then | walking backwards | on the same side 3 m in and at the end "
          f"(correlation) |\n|---|---|---|---|---|---|---|---|")
    for name, traj in runs.items():
        rho = empirical.bot_measures(traj, np.random.default_rng(0))[0]
        p = empirical.bot_passing(traj)
        same, corr = empirical.bot_exit_sides(traj)
        print(f"| {name} | {rho:.2f}/m² | {p.meeting:.0%} | {p.speed_meeting:.2f} m/s | {p.speed_others:.2f} m/s | "
              f"{p.stopped:.0%} | {p.backwards:.1%} | {same:.0%} ({corr:.2f}) |")


def _snapshot(ax, traj, title: str) -> None:
    """The corridor (x 9-17) at the frame holding the most people in the measurement area."""
    inside = traj.active_mask & np.all((traj.positions >= empirical.BOT_AREA[0])
                                       & (traj.positions <= empirical.BOT_AREA[1]), axis=2)
    f = int(inside.sum(axis=1).argmax())
    east = np.char.startswith(traj.group.astype(str), "east")
    for sel, colour, label in ((east, "tab:red", "walking +x"), (~east, "tab:blue", "walking -x")):
        m = traj.active_mask[f] & sel & (traj.positions[f, :, 0] >= 9) & (traj.positions[f, :, 0] <= 17)
        for x, y in traj.positions[f, m]:
            ax.add_patch(plt.Circle((x, y), empirical.RADIUS, color=colour, alpha=0.8))
        ax.plot([], [], "o", color=colour, label=label)
    ax.axhline(0, color="k")
    ax.axhline(3.6, color="k")
    ax.add_patch(plt.Rectangle(empirical.BOT_AREA[0], 2.0, 3.6, fill=False, ls="--", color="gray"))
    ax.set_xlim(9, 17)
    ax.set_ylim(-0.2, 3.8)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=6, loc="upper right")


def lanes_figure(counter: dict, measured: dict | None) -> None:
    fig = plt.figure(figsize=(9, 6.5))
    ax = fig.add_subplot(2, 1, 1)
    ours = [(empirical.bot_measures(o.traj, np.random.default_rng(0)), name) for name, o in counter.items()]
    pts = np.array([m for m, _ in ours])
    ax.plot(pts[:, 0], pts[:, 2], "v", color="tab:red", label="crowdmotion rvo, lane order (per seed)")
    ax.plot(pts[:, 0], pts[:, 3], "v", color="tab:red", mfc="none", label="crowdmotion rvo, directions shuffled")
    if measured:
        real = np.array([m for _, m in measured.values()])
        ax.plot(real[:, 0], real[:, 2], "^", color="tab:purple", label="FZJ BOT-360 as measured, lane order")
        ax.plot(real[:, 0], real[:, 3], "^", color="tab:purple", mfc="none",
                label="FZJ BOT-360 as measured, directions shuffled")
        ax.plot(real[:, 0], 2 * real[:, 3], "_", color="tab:purple", ms=12, label="twice the shuffled value (FZJ)")
    ax.set_xlabel("density in the measurement area (persons/m²)")
    ax.set_ylabel("lane order")
    ax.set_ylim(0, 1.1)
    ax.legend(fontsize=6, ncol=2, loc="lower left")
    ax.set_title("Lanes in counterflow (3.6 m corridor): ((same - opposite) / (same + opposite))² within 2 m "
                 "along, 0.3 m across", fontsize=8)
    b16 = next(o for name, o in counter.items() if name.startswith("BOT b 1.6"))
    _snapshot(fig.add_subplot(2, 2, 3), b16.traj, "crowdmotion rvo, entrances 1.6 m (seed 0), fullest frame")
    if measured and "bot-360-160-160" in measured:
        _snapshot(fig.add_subplot(2, 2, 4), measured["bot-360-160-160"][0],
                  "FZJ bot-360-160-160 as measured, fullest frame")
    fig.tight_layout()
    fig.savefig(IMG / "empirical_lanes.png", dpi=110)
    print(f"wrote {IMG / 'empirical_lanes.png'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fzj", type=Path, help="folder of the FZJ bot-360-*.txt trajectory files (OpenTraj's "
                                             "datasets/HERMES/Corridor-2D)")
    args = ap.parse_args()
    measured = fzj_runs(args.fzj) if args.fzj else None
    if measured:
        print("| measured run | density | speed | lane order | shuffled | ratio |\n|---|---|---|---|---|---|")
        for name, (_, (rho, v, order, base)) in measured.items():
            print(f"| {name} | {rho:.2f}/m² | {v:.2f} m/s | {order:.2f} | {base:.2f} | {order / base:.2f} |")
    corridor, v1 = run("fd_open_corridor")
    bottle, v2 = run("bottleneck_flow")
    counter, v3 = run("counterflow_lanes")
    print(verify.table([v1, v2, v3]))
    print_passing({**{name: traj for name, (traj, _) in (measured or {}).items()},
                   **{f"crowdmotion {name}": o.traj for name, o in counter.items()}})

    rho = np.linspace(0.1, 5.3, 300)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(rho, weidmann_speed(rho), "k-", label="Weidmann 1993")
    ax.plot(rho, WEIDMANN_FREE * speed_share(rho, GAMMA), "k:",
            label=f"cap used (Weidmann's form, γ = {GAMMA} fitted to FZJ)")
    ax.plot(rho, empirical.BOT_FREE_SPEED * speed_share(rho, GAMMA), ":", color="tab:purple",
            label=f"the same cap at the BOT-360 participants' free speed ({empirical.BOT_FREE_SPEED:.2f} m/s)")
    ug = np.array(empirical.UG_RUNS)
    ax.plot(ug[:, 0], ug[:, 1], "s", color="tab:gray", label="FZJ closed corridor 1.8 m (Zhang 2011)")
    bot = np.array(empirical.BOT_360_RUNS)
    ax.plot(bot[:, 0], bot[:, 1], "^", color="tab:purple", mfc="none", label="FZJ BOT-360 counterflow (Zhang 2012)")
    per_seed = []
    for name, o in corridor.items():
        start, end, _ = empirical.stationary(verify.crossing_times(o.traj, 0, 18.2))
        per_seed.append(empirical.area_density_speed(o.traj, *empirical.UO_AREA, start, end))
    per_seed = np.array(per_seed)
    ax.plot(per_seed[:, 0], per_seed[:, 1], "o", color="tab:blue", label="crowdmotion rvo, open corridor (per seed)")
    cf = np.array(bot_points(counter))
    ax.plot(cf[:, 0], cf[:, 1], "v", color="tab:red", label="crowdmotion rvo, BOT-360 counterflow (per seed)")
    ax.set_xlabel("density (persons/m²)")
    ax.set_ylabel("speed (m/s)")
    ax.set_xlim(0, 5.5)
    ax.set_ylim(0, 1.6)
    ax.legend(fontsize=7)
    ax.set_title("Speed against density: measured crowds and crowdmotion (default parameters)", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMG / "empirical_speed_density.png", dpi=110)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    labels = {0: "Kretz et al. 2006", 1: "Seyfried et al. 2009", 2: "FZJ/Wuppertal 2006"}
    for b, flows in empirical.BOTTLENECK_FLOWS.items():
        ax.plot(np.full(len(flows), b), flows, "s", color="tab:gray", ms=4)
    means = {b: np.mean(f) for b, f in empirical.BOTTLENECK_FLOWS.items()}
    bs = np.array(sorted(means))
    ax.fill_between(bs, [0.75 * means[b] for b in bs], [1.25 * means[b] for b in bs], color="tab:gray", alpha=0.15,
                    label="data mean ± 25 %")
    ax.plot([], [], "s", color="tab:gray", ms=4, label="measured (" + ", ".join(labels.values()) + ")")
    for name, o in bottle.items():
        b = float(name.split("/")[0].split()[1])
        j = empirical.stationary(verify.crossing_times(o.traj, 0, 12.0))[2]
        ax.plot(b, j, "o", color="tab:blue", ms=5)
    ax.plot([], [], "o", color="tab:blue", label="crowdmotion rvo (per seed)")
    ax.set_xlabel("bottleneck width (m)")
    ax.set_ylabel("flow (persons/s)")
    ax.legend(fontsize=7)
    ax.set_title("Bottleneck flow against width: 200 persons, 10 x 8 m room, 2 m long bottleneck", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMG / "empirical_bottleneck.png", dpi=110)
    print(f"wrote {IMG / 'empirical_speed_density.png'} and {IMG / 'empirical_bottleneck.png'}")
    lanes_figure(counter, measured)


if __name__ == "__main__":
    main()
