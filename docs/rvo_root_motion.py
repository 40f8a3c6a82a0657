"""Print the root-motion table of docs/rvo.md: every RVO built-in run as shipped, with its
steps as simulated (``smoothing = "none"``: no relaxation for the characters), and with
comfortable acceleration switched off (eq. (3)'s free choice; relaxed).

    python docs/rvo_root_motion.py            # the built-ins but the stand evacuation
    python docs/rvo_root_motion.py --all      # with it (2000 people: a few minutes)

For each run: ``crowdmotion.metrics.root_motion`` of its walkers (radius up to 0.4 m; the
term leaves wider bodies alone) as a DCC plays them (24 fps along the B-spline of the
run's frames: acceleration, turn rate and deviation from the 1 s moving average, 95th
percentiles), the continuous-time audit, the mean time to goal and the run's wall time.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.metrics import collision_audit, root_motion
from crowdmotion.rvo.adapter import run_scenario as run_rvo
from crowdmotion.rvo.density import PERSON_MAX_RADIUS_M
from crowdmotion.scenario import load_scenario


# (comfort_accel, smoothing) as the table shows them, and the parameters that make them
VARIANTS = [("0.8 m/s²", "relaxed", {}), ("0.8 m/s²", "none", {"smoothing": "none"}),
            ("off", "relaxed", {"comfort_accel": 0.0})]


def row(path, variant) -> str:
    scenario = load_scenario(path)
    comfort, smoothing, update = variant
    params = scenario.params.model_copy(update=update)
    t = time.perf_counter()
    traj, _, summary = run_rvo(scenario.scene, scenario.groups, params, np.random.default_rng(scenario.spec.seed),
                               progress=False)
    wall = time.perf_counter() - t
    people = np.flatnonzero(traj.radius <= PERSON_MAX_RADIUS_M)
    name = path.stem if len(people) else f"{path.stem} (no walkers: all wider than {PERSON_MAX_RADIUS_M} m)"
    rm = root_motion(traj.select(agents=people if len(people) else None))
    audit = collision_audit(traj, scenario.scene)
    acc, turn, dev = rm["acceleration_mps2"], rm["turn_rate_rad_s"], rm["deviation_from_1s_average_m"]
    t_goal = summary.get("mean_time_to_goal_s")
    return (f"| {name} | {comfort} | {smoothing} | {acc['p95']:.2f} | {turn['p95']:.2f} | "
            f"{100 * dev['p95']:.1f} | {audit.agent_agent} / {audit.agent_obstacle} | "
            f"{t_goal:.1f} | {wall:.1f} |")


def main() -> None:
    print("| scene | comfort_accel | smoothing | acceleration p95, m/s² | turn rate p95, rad/s | deviation p95, cm "
          "| overlaps / penetrations | mean time to goal, s | run, s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in builtin_scenarios():
        if path.stem.startswith("rvo_") and ("--all" in sys.argv or path.stem != "rvo_stand_evacuation"):
            for variant in VARIANTS:
                print(row(path, variant), flush=True)


if __name__ == "__main__":
    main()
