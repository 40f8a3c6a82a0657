"""Make the figures and the measured table of docs/rvo.md from the built-in scenes.

    python docs/make_rvo_figures.py [--seeds 5]

Runs the five street crossings (O, C, E, A, N: + group against - group) with several
seeds, writes docs/img/rvo_street_<T>.png (paths, first seed), docs/img/rvo_personality.png
(per-group measures, mean ± sd over seeds) and prints the markdown table of which of the
paper's §6 observations hold.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from crowdmotion.cli import builtin_scenarios
from crowdmotion.render import plot_group_report, plot_paths
from crowdmotion.scenario import load_scenario, run_scenario

IMG = Path(__file__).parent / "img"
KEYS = ("lateral_spread_m", "lateral_deviation_m", "heading_change_rate_rad_s", "mixing_index",
        "same_group_neighbors", "speed_density_slope", "mean_speed_mps", "path_length_ratio")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    scenes = {p.stem: p for p in builtin_scenarios()}
    per_group: dict[str, dict[str, list[float]]] = {}
    for trait in "OCEAN":
        sc = load_scenario(scenes[f"rvo_street_{trait}"])
        for seed in range(args.seeds):
            res = run_scenario(sc, seed=seed, progress=False)
            s = res.summary
            assert s["agent_agent_overlaps"] == 0 and s["agent_obstacle_penetrations"] == 0
            if seed == 0:
                plot_paths(res.trajectories, sc.scene, IMG / f"rvo_street_{trait}.png",
                           title=f"street crossing, {trait}+ (blue) against {trait}- (orange)")
            for g, row in s["groups"].items():
                acc = per_group.setdefault(g, {k: [] for k in KEYS})
                for k in KEYS:
                    if row[k] is not None:
                        acc[k].append(row[k])
    stats = {g: {k: (float(np.mean(v)), float(np.std(v))) if v else None for k, v in acc.items()}
             for g, acc in per_group.items()}
    order = [f"{t}{s}" for t in "OCEAN" for s in "+-"]
    plot_group_report({g: stats[g] for g in order}, IMG / "rvo_personality.png",
                      title=f"street crossings, mean ± sd over {args.seeds} seeds")

    def m(g, k):
        return stats[g][k][0]

    def fmt(g, k):
        mu, sd = stats[g][k]
        return f"{mu:.2f} ± {sd:.2f}"

    checks = [
        ("O+ walks spread wider than O−", "lateral_spread_m", "O+", "O-", ">"),
        ("E+ walks spread wider than E−", "lateral_spread_m", "E+", "E-", ">"),
        ("C+ changes direction less than C−", "heading_change_rate_rad_s", "C+", "C-", "<"),
        ("A+ mixes into the other group more than A−", "mixing_index", "A+", "A-", ">"),
        ("A− forms clusters (more same-group neighbours than A+)", "same_group_neighbors", "A-", "A+", ">"),
        ("N+ walks in a narrower band than N−", "lateral_spread_m", "N+", "N-", "<"),
    ]
    print("| observation (paper §6) | measure | + group | − group | holds? |")
    print("|---|---|---|---|---|")
    for text, key, a, b, op in checks:
        ok = m(a, key) > m(b, key) if op == ">" else m(a, key) < m(b, key)
        pa, pb = (a, b) if a.endswith("+") else (b, a)
        print(f"| {text} | {key} | {fmt(pa, key)} | {fmt(pb, key)} | {'yes' if ok else 'no'} |")
    narrowest = min(order, key=lambda g: m(g, "lateral_spread_m"))
    print(f"| N+ is the narrowest of all ten groups | lateral_spread_m | {fmt('N+', 'lateral_spread_m')} | "
          f"narrowest: {narrowest} {fmt(narrowest, 'lateral_spread_m')} | {'yes' if narrowest == 'N+' else 'no'} |")
    slopes = [m(g, "speed_density_slope") for g in order]
    print(f"| dense areas slow agents down | speed_density_slope < 0 | {sum(s < 0 for s in slopes)} of 10 groups | "
          f"range {min(slopes):.2f} to {max(slopes):.2f} | {'yes' if all(s < 0 for s in slopes) else 'partly'} |")
    print("\nall groups (mean over seeds):\n")
    print("| group | " + " | ".join(KEYS) + " |")
    print("|---" * (len(KEYS) + 1) + "|")
    for g in order:
        print(f"| {g} | " + " | ".join(f"{m(g, k):.3f}" for k in KEYS) + " |")


if __name__ == "__main__":
    main()
