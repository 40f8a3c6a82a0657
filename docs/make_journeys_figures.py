"""Make the pictures and the measured figures of docs/journeys.md's built-in scenes.

    python docs/make_journeys_figures.py

Runs rvo_station_concourse, rvo_town_square and rvo_stand_exits at their defaults, writes
docs/img/<scene>.png (every path over the scene) and the concourse's queues and exits over
time (docs/img/rvo_station_concourse_journeys.png), and prints per scene its run time, the
audit, the time the last agent left, and per queue its waits, per exit who left by it;
then the stand four ways (a random point of the concourse, the nearest exit, the least
crowded exit chosen once and weighed again) with the evacuation time of each, and how
many came out by another exit's door.
"""

from __future__ import annotations

import textwrap
import time
from pathlib import Path

import numpy as np

from crowdmotion.builtin import builtin_scenarios
from crowdmotion.render import plot_journeys, plot_paths
from crowdmotion.scenario import load_scenario, parse_scenario, run_scenario

IMG = Path(__file__).parent / "img"
SCENES = ("rvo_station_concourse", "rvo_town_square", "rvo_stand_exits")
CONCOURSE = 'goal = { shape = "rect", lower = [0.5, 0.5], upper = [29.5, 5.0] }\nattributes ='


DOORS = {"west exit": (4.0, 6.0), "middle exit": (10.0, 12.0), "east exit": (25.0, 27.0)}  # rvo_stand_exits
WALL_Y = 8.5


def other_door(res) -> int:
    """Spectators of rvo_stand_exits who came out by a door other than their exit's (the
    one whose strip they left by) and walked under the wall to it."""
    traj, names = res.trajectories, res.trajectories.metadata["stages"]["spectators"]
    count = 0
    for a in range(traj.n_agents):
        seen = traj.stage[:, a][traj.stage[:, a] >= 0]
        exit_ = names[int(seen[-1])]["name"] if len(seen) else None
        y = traj.positions[:, a, 1]
        cross = np.flatnonzero(traj.active_mask[:-1, a] & traj.active_mask[1:, a] & (y[:-1] >= WALL_Y) & (y[1:] < WALL_Y))
        if exit_ in DOORS and len(cross):
            lo, hi = DOORS[exit_]
            count += not lo <= traj.positions[cross[0], a, 0] <= hi
    return count


def last_out(traj) -> float:
    """When the last agent left the scene (s)."""
    return float(traj.times[np.flatnonzero(traj.active_mask.any(axis=1))[-1]])


def stand_variants(text: str) -> dict[str, str]:
    """rvo_stand_exits to a random point of the concourse (no route), the nearest exit,
    the least crowded exit chosen once, and weighed again on the way (the built-in's)."""
    a, b = text.index("[[groups.route]]"), text.index("[rvo]")
    once = "\n".join(line for line in text.splitlines() if not line.startswith("rechoose")) + "\n"
    return {"random point of the concourse (`goal_assignment = \"sample\"`)":
            text[:a].replace("attributes =", CONCOURSE) + text[b:] + 'goal_assignment = "sample"\n',
            "nearest exit (`by = \"nearest\"`)": once.replace('by = "least_crowded"', 'by = "nearest"'),
            "least crowded exit, chosen once (`by = \"least_crowded\"`)": once,
            "least crowded exit, weighed again every 2 s (`rechoose = 2.0`, the built-in's)": text}


def main() -> None:
    paths = {p.stem: p for p in builtin_scenarios()}
    for name in SCENES:
        sc = load_scenario(paths[name])
        t0 = time.perf_counter()
        res = run_scenario(sc, progress=False)
        took = time.perf_counter() - t0
        s, traj = res.summary, res.trajectories
        plot_paths(traj, sc.scene, IMG / f"{name}.png", title=textwrap.fill(sc.spec.description, 80))
        if name == "rvo_station_concourse":
            plot_journeys(res.extras.journeys, IMG / f"{name}_journeys.png", title=name)
        j = s["journeys"]
        print(f"\n{name}: {traj.n_agents} agents, run {took:.1f} s, last out at {last_out(traj):.1f} s, "
              f"route finished {j['finished']}/{j['on_route']}, overlaps {s['agent_agent_overlaps']}, "
              f"penetrations {s['agent_obstacle_penetrations']}")
        for q, v in j["queues"].items():
            print(f"  {q}: {v['served']} served, wait in line mean {v['mean_wait_s']:.1f} s, longest "
                  f"{v['max_wait_s']:.1f} s, longest line {max(v['length_per_s'] or [0])}")
        for e, v in sorted(j["exits"].items()):
            print(f"  {e}: {v['left']} left, last at {v['evacuation_time_s']:.1f} s")
        for g, rows in j["stages"].items():
            for r in rows:
                if r["kind"] == "wait" and r["mean_time_s"] is not None:
                    print(f"  {g}, {r['name']}: mean {r['mean_time_s']:.1f} s, longest {r['max_time_s']:.1f} s")
    print("\n| rvo_stand_exits, each spectator to | everyone out after | overlaps / penetrations |")
    print("|---|---|---|")
    for label, text in stand_variants(paths["rvo_stand_exits"].read_text()).items():
        s = (res := run_scenario(parse_scenario(text), progress=False)).summary
        exits = s.get("journeys", {}).get("exits", {})
        split = " (" + ", ".join(f"{e}: {v['left']}" for e, v in sorted(exits.items())) + ")" if exits else ""
        print(f"| {label} | {last_out(res.trajectories):.2f} s{split} | {s['agent_agent_overlaps']} / "
              f"{s['agent_obstacle_penetrations']} |" + (f" {other_door(res)} came out by another exit's door"
                                                          if exits else ""))


if __name__ == "__main__":
    main()
