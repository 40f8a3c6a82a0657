"""Print the root-motion table of docs/formation.md: every formation built-in run as
shipped and with comfortable motion switched off (the paper's kinematic mesh).

    python docs/formation_root_motion.py

For each run: ``crowdmotion.metrics.root_motion`` of its walkers (cars are reported
apart: the term leaves them alone) at the 24 fps the run writes (acceleration, turn
rate and deviation from the 1 s moving average, 95th percentiles, and the largest
acceleration), the continuous-time audit, how often the safety pass stopped an agent,
and when the groups recovered.
"""

from __future__ import annotations

import time

import numpy as np

from crowdmotion.cli import builtin_scenarios
from crowdmotion.formation.adapter import run_scenario as run_formation
from crowdmotion.metrics import collision_audit, root_motion
from crowdmotion.scenario import load_scenario

OFF = {"mesh_acceleration": 0.0, "vertex_gap": 0.0}


def row(path, off: bool) -> str:
    scenario = load_scenario(path)
    params = scenario.params.model_copy(update=OFF if off else {})
    t = time.perf_counter()
    traj, run, summary = run_formation(scenario.scene, scenario.groups, params,
                                       np.random.default_rng(scenario.spec.seed), progress=False)
    wall = time.perf_counter() - t
    cars = [g for g in run.simulator.groups if g.cars]
    who = np.concatenate([g.agents for g in run.simulator.groups if not g.cars] or [np.zeros(0, int)])
    kind = "walkers" if len(who) else "cars"
    if not len(who):
        who = np.concatenate([g.agents for g in cars])
    rm = root_motion(traj.select(agents=who))
    audit = collision_audit(traj, scenario.scene)
    recovered = ", ".join(f"{g['recovered_s']:.1f}" if g["recovered_s"] is not None else "never"
                          for g in summary["formation"].values())
    acc, turn, dev = rm["acceleration_mps2"], rm["turn_rate_rad_s"], rm["deviation_from_1s_average_m"]
    return (f"| {path.stem} ({kind}) | {'off' if off else 'on'} | {acc['p95']:.2f} ({acc['max']:.0f}) | "
            f"{turn['p95']:.2f} | {dev['p95']:.3f} | {audit.agent_agent} / {audit.agent_obstacle} | "
            f"{summary['rules']['safety_stops']} | {recovered} | {wall:.2f} |")


def main() -> None:
    print("| scene | comfortable motion | acceleration p95 (max), m/s² | turn rate p95, rad/s | deviation p95, m "
          "| overlaps / penetrations | safety stops | recovered at, s | run, s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in builtin_scenarios():
        if path.stem.startswith("formation_"):
            for off in (True, False):
                print(row(path, off), flush=True)


if __name__ == "__main__":
    main()
