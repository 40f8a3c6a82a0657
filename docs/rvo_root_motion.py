"""Print the root-motion table of docs/rvo.md: every RVO built-in run as shipped, with its
steps as simulated (``smoothing = "none"``: no relaxation for the characters), and with
comfortable acceleration switched off (eq. (3)'s free choice; relaxed).

    python docs/rvo_root_motion.py            # the built-ins but the stand evacuation
    python docs/rvo_root_motion.py --all      # with it (2000 people: a few minutes)
    python docs/rvo_root_motion.py --figure   # docs/img/rvo_relaxed_steps.png

For each run: ``crowdmotion.metrics.root_motion`` of its walkers (radius up to 0.4 m; the
term leaves wider bodies alone) as a DCC plays them (24 fps along the B-spline of the
run's frames: acceleration, turn rate and deviation from the 1 s moving average, 95th
percentiles), the continuous-time audit, the mean time to goal and the run's wall time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.metrics import collision_audit, root_motion
from crowdmotion.rvo.adapter import run_scenario as run_rvo
from crowdmotion.rvo.density import PERSON_MAX_RADIUS_M
from crowdmotion.rvo.params import RVOParams
from crowdmotion.scenario import load_scenario


# (comfort_accel, smoothing) as the table shows them, and the parameters that make them
SHIPPED = f"{RVOParams.model_fields['comfort_accel'].default:.1f} m/s²"  # the default, as it is
VARIANTS = [(SHIPPED, "relaxed", {}), (SHIPPED, "none", {"smoothing": "none"}),
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


def figure(out: Path = Path(__file__).parent / "img" / "rvo_relaxed_steps.png") -> None:
    """One evacuee of the stand evacuation in the crush before an exit, as a character
    plays it at 24 fps (along the B-spline of the frames): its path and its speed, from
    the steps as simulated and from the relaxed ones the run returns."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from crowdmotion.rvo.simulation import run
    from crowdmotion.trajectories import resample

    path = next(p for p in builtin_scenarios() if p.stem == "rvo_stand_evacuation")
    sc = load_scenario(path)
    res = run(sc.scene, sc.groups, sc.params, np.random.default_rng(sc.spec.seed))
    steps, relaxed = res.steps, res.trajectories
    # the agent with the most stop-and-go (largest wobble about its 1 s average) that walks
    # at least 10 s
    played = {k: resample(t, 24.0, "b-spline") for k, t in (("steps as simulated", steps), ("relaxed", relaxed))}
    p = played["steps as simulated"].positions
    act = played["steps as simulated"].active_mask
    kernel = np.ones(25) / 25
    wobble = np.zeros(p.shape[1])
    for i in range(p.shape[1]):
        f = np.flatnonzero(act[:, i])
        if len(f) > 240:
            xy = p[f, i]
            mean = np.stack([np.convolve(xy[:, k], kernel, mode="valid") for k in range(2)], axis=1)
            wobble[i] = np.percentile(np.linalg.norm(xy[12:-12] - mean, axis=1), 95)
    who = int(np.argmax(wobble))
    fig, (ax_path, ax_speed) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1, 3]})
    for (label, tr), colour in zip(played.items(), ("tab:red", "tab:blue")):
        f = np.flatnonzero(tr.active_mask[:, who])
        xy = tr.positions[f, who]
        ax_path.plot(xy[:, 0], xy[:, 1], color=colour, lw=1.2, label=label)
        speed = np.linalg.norm(np.diff(xy, axis=0), axis=1) / tr.dt
        ax_speed.plot(tr.times[f[1:]], speed, color=colour, lw=1.0, label=label)
    ax_path.set_aspect("equal")
    ax_path.set_xlabel("x (m)")
    ax_path.set_ylabel("y (m)")
    ax_path.set_title(f"evacuee {who}: path at 24 fps")
    ax_speed.legend(fontsize=9, loc="upper left")
    ax_speed.set_xlabel("time (s)")
    ax_speed.set_ylabel("speed (m/s)")
    ax_speed.set_title("speed at 24 fps")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out} (agent {who}, wobble p95 {100 * wobble[who]:.1f} cm as simulated)")


def main() -> None:
    print("| scene | comfort_accel | smoothing | acceleration p95, m/s² | turn rate p95, rad/s | deviation p95, cm "
          "| overlaps / penetrations | mean time to goal, s | run, s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in builtin_scenarios():
        if path.stem.startswith("rvo_") and ("--all" in sys.argv or path.stem != "rvo_stand_evacuation"):
            for variant in VARIANTS:
                print(row(path, variant), flush=True)


if __name__ == "__main__":
    figure() if "--figure" in sys.argv else main()
