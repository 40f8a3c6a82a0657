"""Make the figures and the measured table of docs/rvo.md from the built-in scenes.

    python docs/make_rvo_figures.py [--seeds 20]

Runs the five street crossings (O, C, E, A, N: + group against - group) with several
seeds, writes docs/img/rvo_street_<T>.png (paths, first seed), docs/img/rvo_personality.png
(per-group measures, mean ± sd over seeds) and prints the markdown tables of which of the
paper's §6 observations hold (crowdmotion.rvo.claims: paired differences over the seeds
with 95 % confidence intervals), over the seeds and with each scene's default seed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from crowdmotion.cli import builtin_scenarios
from crowdmotion.render import plot_group_report, plot_paths
from crowdmotion.rvo import personality
from crowdmotion.rvo.claims import check_claims, format_claims, mean_ci
from crowdmotion.scenario import load_scenario, run_scenario

IMG = Path(__file__).parent / "img"
KEYS = ("lateral_spread_m", "lateral_deviation_m", "heading_change_rate_rad_s", "mixing_index",
        "same_group_neighbors", "cluster_size", "clusters", "speed_density_slope", "mean_speed_mps",
        "path_length_ratio")


def n_plus_experiment(scenes: dict, seeds: int) -> None:
    """Which of N+'s Table 4 parameters makes it walk wider than N-: the street N scene
    with N+'s row changed one entry at a time to N-'s (and all at once), over the seeds."""
    sc = load_scenario(scenes["rvo_street_N"])
    table = personality.TABLE4["N+"]
    minus = personality.TABLE4["N-"]
    variants = {"Table 4": table}
    for k, name in enumerate(("M", "D", "N_sample", "w")):
        if table[k] != minus[k]:
            variants[f"{name} = {minus[k]} (N-'s)"] = tuple(minus[k] if j == k else v for j, v in enumerate(table))
    variants["all four of N-'s"] = minus
    print("\nN+ against N-: lateral spread difference (m), mean ± 95 % CI over the seeds\n")
    print("| N+ row (M, D, N_sample, w) | N+ - N- |")
    print("|---|---|")
    try:
        for name, row in variants.items():
            personality.TABLE4["N+"] = row
            d = []
            for seed in range(seeds):
                g = run_scenario(sc, seed=seed, progress=False).summary["groups"]
                d.append(g["N+"]["lateral_spread_m"] - g["N-"]["lateral_spread_m"])
            m, h, _ = mean_ci(d)
            print(f"| {name}: {row} | {m:+.3f} ± {h:.3f} |")
    finally:
        personality.TABLE4["N+"] = table


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args()
    scenes = {p.stem: p for p in builtin_scenarios()}
    per_group: dict[str, dict[str, list[float]]] = {}
    # one report per seed holding all ten groups (the five scenes' + and - poles), so that
    # "N+ is the narrowest of all" compares within a seed
    reports: list[dict] = [{} for _ in range(args.seeds)]
    defaults: dict = {}
    for trait in "OCEAN":
        sc = load_scenario(scenes[f"rvo_street_{trait}"])
        defaults.update(run_scenario(sc, progress=False).summary["groups"])
        for seed in range(args.seeds):
            res = run_scenario(sc, seed=seed, progress=False)
            reports[seed].update(res.summary["groups"])
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
    stats = {g: {k: mean_ci(v)[:2] if v else None for k, v in acc.items()} for g, acc in per_group.items()}
    order = [f"{t}{s}" for t in "OCEAN" for s in "+-"]
    plot_group_report({g: stats[g] for g in order}, IMG / "rvo_personality.png",
                      title=f"street crossings, mean ± 95 % confidence interval over {args.seeds} seeds")

    def m(g, k):
        return stats[g][k][0]

    print(format_claims(check_claims(reports)))
    print("\ndefault seed of each street scene:\n")
    print(format_claims(check_claims([defaults])))
    n_plus_experiment(scenes, args.seeds)
    print("\nall groups (mean over seeds):\n")
    print("| group | " + " | ".join(KEYS) + " |")
    print("|---" * (len(KEYS) + 1) + "|")
    for g in order:
        print(f"| {g} | " + " | ".join(f"{m(g, k):.3f}" for k in KEYS) + " |")


if __name__ == "__main__":
    main()
