"""Print the root-motion table of docs/pso.md: every PSO built-in run as shipped
(``pso.smoothing = "relaxed"``) and with ``smoothing = "linear"`` (the paper's iterates,
played as straight moves between them).

    python docs/pso_root_motion.py

For each run, from its ``summary.json`` figures (``crowdmotion run <scene>``):
``crowdmotion.metrics.root_motion`` (24 fps along the B-spline of the run's frames:
acceleration, turn rate and deviation from the 1 s moving average, 95th percentiles),
the fastest speed against the group's max_speed, the continuous-time audit, the arrival
rate, the mean time to goal, how many path steps the audit made keep their straight move,
and the run's wall time (the run, its relaxation and the summary's figures).
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.pso.adapter import run_scenario
from crowdmotion.scenario import load_scenario


def row(path, smooth: bool) -> str:
    scenario = load_scenario(path)
    params = scenario.params
    params = params.model_copy(update={"smoothing": "relaxed" if smooth else "linear"})
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, _, s = run_scenario(scenario.scene, scenario.groups, params, np.random.default_rng(scenario.spec.seed),
                               progress=False)
    wall = time.perf_counter() - t
    rm = s["root_motion"]
    acc, turn, dev = rm["acceleration_mps2"], rm["turn_rate_rad_s"], rm["deviation_from_1s_average_m"]
    top = max(g.max_speed for g in scenario.groups)
    t_goal = s.get("mean_time_to_goal_s")
    kept = s["smoothing"].get("straight_segments")
    straight = "-" if kept is None else f"{kept} / {s['smoothing']['segments']}"
    return (f"| {path.stem} | {s['smoothing']['kind']} | {acc['p95']:.2f} | {turn['p95']:.2f} | "
            f"{100 * dev['p95']:.1f} | {s['max_speed_mps']:.3f} / {top:g} | "
            f"{s['agent_agent_overlaps']} / {s['agent_obstacle_penetrations']} | {100 * s['arrival_rate']:.0f} % | "
            f"{'-' if t_goal is None else f'{t_goal:.1f}'} | {straight} | {wall:.1f} |")


def main() -> None:
    print("| scene | smooth | acceleration p95, m/s² | turn rate p95, rad/s | deviation p95, cm "
          "| max speed / max_speed, m/s | overlaps / penetrations | arrived | mean time to goal, s "
          "| steps kept straight | run, s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    only = [a for a in sys.argv[1:] if not a.startswith("-")]
    for path in builtin_scenarios():
        if path.stem.startswith("pso_") and (not only or path.stem in only):
            for smooth in (True, False):
                print(row(path, smooth), flush=True)


if __name__ == "__main__":
    main()
