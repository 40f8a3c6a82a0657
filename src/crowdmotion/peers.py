"""The peers' own example scenes as their authors wrote them ("everyone home"):
RVO2's Circle and Roadmap examples, Menge's 4square and five SteerSuite test cases, as
``crowdmotion verify`` cases for the RVO method, each judged by its author's own success
test. Read from the sources named in each builder: agent counts, radii, speeds, goals,
obstacles, the time step where the peer fixes one, agents kept at or removed from their
goal as the peer does. Nothing here is tuned to make crowdmotion pass.

SteerSuite's test cases lie in the x-z plane (y up); they are read as x -> x, z -> y.
"""

from __future__ import annotations

import numpy as np

from crowdmotion.cases import Case, Outcome, Setup
from crowdmotion.groups import Group, Points, Rect
from crowdmotion.scene import Box, Scene


def _arrived(r: Outcome) -> float:
    return float(r.summary.get("arrival_rate", 0.0))


def _all_at_goals_s(r: Outcome, goals: np.ndarray, within: float) -> tuple[int, float | None]:
    """(how many agents were ever within ``within`` metres of their goal, the first time all
    were at once or None): the stopping test of RVO2's examples, arrived agents staying."""
    d = np.linalg.norm(r.traj.positions - goals[None], axis=2) <= within
    ever = int(d.any(axis=0).sum())
    frames = np.flatnonzero(d.all(axis=1))
    return ever, (float(frames[0] * r.traj.dt) if len(frames) else None)


def _duration_s(r: Outcome) -> float:
    return float((r.traj.n_frames - 1) * r.traj.dt)


def _last_arrival_s(r: Outcome) -> float | None:
    """Seconds until the last agent arrived (removed at its target), None if one never did."""
    if _arrived(r) < 1.0:
        return None
    present = r.traj.active_mask
    return float((present.shape[0] - 1 - np.argmax(present[::-1], axis=0)).max() * r.traj.dt)


# ---- RVO2's Circle (snape/RVO2, examples/Circle.cc) -----------------------------------------
# setAgentDefaults(15, 10, 10, 10, 1.5, 2): neighbour distance 15 m, 10 neighbours, time
# horizons 10 s (ORCA's; our sampling RVO has none), radius 1.5 m, max speed 2 m/s; time
# step 0.25 s; 250 agents at 200 (cos, sin)(i 2π 0.004), goals their antipodes. Preferred
# velocity: the vector to the goal cut to unit length, so 1 m/s (and slower within 1 m).
# Agents stay at their goals; the example runs until every agent is within its radius of
# its goal at the same time (reachedGoal). RVO2 itself (pyrvo 0.4.3,
# benchmarks/rvo2_examples.py circle; the example has no randomness): all 250 at their goals
# at 748.25 s, with bodies overlapping by up to 0.71 m on the way.
RVO2_CIRCLE_S = 748.25


def _rvo2_circle(method: str) -> dict[str, Setup]:
    ang = np.arange(250) * 2 * np.pi * 0.004
    start = 200.0 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    g = Group("circle", 250, spawn=Points(start), goal=Points(-start), radius=1.5, max_speed=2.0, pref_speed=1.0)
    params = {"time_step": 0.25, "neighbor_dist": 15.0, "max_neighbors": 10, "remove_on_arrival": False,
              "arrival_radius": 1.5, "max_steps": 8000}
    return {"circle": Setup(Scene(bounds=([-210, -210], [210, 210])), [g], params)}


def _judge_rvo2_circle(out: dict[str, Outcome]) -> tuple[str, str, bool]:
    r = out["circle"]
    ever, at_once = _all_at_goals_s(r, -r.traj.positions[0], 1.5)
    measured = f"{ever} of 250 reached their goal; " + (
        f"all at their goals at once at {at_once:.0f} s" if at_once is not None else
        f"never all at once in {_duration_s(r):.0f} s")
    return (f"all 250 within 1.5 m of their antipodes at once (the example's reachedGoal; RVO2 itself: "
            f"{RVO2_CIRCLE_S:.0f} s)", measured, at_once is not None)


# ---- RVO2's Roadmap (snape/RVO2, examples/Roadmap.cc) ---------------------------------------
# Blocks' scene (four 30 m squares at 10-40 m from the axes; 4 x 25 agents at
# (±(55 + 10 i), ±(55 + 10 j))), setAgentDefaults(15, 10, 5, 5, 2, 2), time step 0.25 s.
# Each corner's 25 agents go to ONE roadmap vertex at the opposite corner, (∓75, ∓75),
# at unit preferred speed (1 m/s, max 2 m/s) towards the visible roadmap vertex nearest
# the goal along a visibility roadmap of 16 vertices round the blocks. crowdmotion has no
# roadmap: its guidance field (exact distances round the obstacles, congestion-aware)
# replaces it. Agents stay; the example runs until every agent is within 20 m of its goal
# vertex at the same time. RVO2 itself (pyrvo 0.4.3, benchmarks/rvo2_examples.py roadmap,
# seeds 1-3 of the example's perturbation): all at once at 944.75, 783.25 and 858.75 s,
# bodies overlapping by up to 0.17-0.22 m.
RVO2_ROADMAP_S = (783.25, 944.75)  # fastest, slowest


BLOCKS = [Box([-40, 10], [-10, 40]), Box([10, 10], [40, 40]), Box([10, -40], [40, -10]), Box([-40, -40], [-10, -10])]


def _rvo2_roadmap(method: str) -> dict[str, Setup]:
    groups = []
    for name, sx, sy in (("north-east", 1, 1), ("north-west", -1, 1), ("south-east", 1, -1), ("south-west", -1, -1)):
        start = np.array([[sx * (55.0 + 10 * i), sy * (55.0 + 10 * j)] for i in range(5) for j in range(5)])
        groups.append(Group(name, 25, spawn=Points(start), goal=[-sx * 75.0, -sy * 75.0], radius=2.0,
                            max_speed=2.0, pref_speed=1.0))
    params = {"time_step": 0.25, "neighbor_dist": 15.0, "max_neighbors": 10, "remove_on_arrival": False,
              "arrival_radius": 20.0, "max_steps": 8000}
    return {"roadmap": Setup(Scene(bounds=([-110, -110], [110, 110]), obstacles=BLOCKS), groups, params)}


def _judge_rvo2_roadmap(out: dict[str, Outcome]) -> tuple[str, str, bool]:
    r = out["roadmap"]
    goals = -75.0 * np.sign(r.traj.positions[0])
    ever, at_once = _all_at_goals_s(r, goals, 20.0)
    ref = f"; RVO2 itself: {RVO2_ROADMAP_S[0]:.0f}-{RVO2_ROADMAP_S[1]:.0f} s"
    measured = f"{ever} of 100 within 20 m; " + (
        f"all at once at {at_once:.0f} s" if at_once is not None else f"never all at once in {_duration_s(r):.0f} s")
    return (f"all 100 within 20 m of their corner's goal vertex at once (the example's reachedGoal{ref})",
            measured, at_once is not None)


# ---- Menge's 4square (MengeCrowdSim/Menge, examples/core/4square.xml, 4square/4squareS.xml,
# 4square/4squareB.xml) -------------------------------------------------------------------------
# Four groups of 25 on 5 x 5 grids (anchor (±7.3, ±7.3), spacing 1.333 m outwards, each
# position displaced 0-0.25 m in a uniform direction: RectGridGenerator + addNoise), goal
# the start mirrored in both axes (GoalSelector "mirror"); Walk -> Stop once within 0.05 m
# of it (goal_reached distance 0.05), Stop holding the agent where it is. Profile group1:
# r 0.2 m, pref_speed 1.34, max_speed 2, neighbor_dist 5, max_neighbors 10; group4 (the
# north-east corner): r 0.35 m, pref_speed 0.75. Common time_step 0.1 s. Four closed 4 x 4 m
# squares at ±(1.333-5.333). Menge ends a run when every agent is in a final state, or at
# the project's duration, 400 s by default (ProjectSpec). The displacements are drawn once
# (seed 4) so that every run sees the same start.
MENGE_DURATION_S = 400.0


def _menge_4square(method: str) -> dict[str, Setup]:
    rng = np.random.default_rng(4)
    squares = [Box([1.333, 1.333], [5.333, 5.333]), Box([-5.333, 1.333], [-1.333, 5.333]),
               Box([-5.333, -5.333], [-1.333, -1.333]), Box([1.333, -5.333], [5.333, -1.333])]
    groups = []
    for name, sx, sy, radius, speed in (("group1", -1, -1, 0.2, 1.34), ("group2", 1, -1, 0.2, 1.34),
                                        ("group3", -1, 1, 0.2, 1.34), ("group4", 1, 1, 0.35, 0.75)):
        i = np.arange(25)
        grid = np.stack([sx * (7.3 + 1.333 * (i % 5)), sy * (7.3 + 1.333 * (i // 5))], axis=1)
        disp, direction = rng.uniform(0.0, 0.25, 25), rng.uniform(0.0, 2 * np.pi, 25)
        start = grid + disp[:, None] * np.stack([np.cos(direction), np.sin(direction)], axis=1)
        groups.append(Group(name, 25, spawn=Points(start), goal=Points(-start), radius=radius, max_speed=2.0,
                            pref_speed=speed))
    params = {"time_step": 0.1, "neighbor_dist": 5.0, "max_neighbors": 10, "remove_on_arrival": False,
              "arrival_radius": 0.05, "max_steps": int(round(MENGE_DURATION_S / 0.1))}
    return {"4square": Setup(Scene(bounds=([-20, -20], [20, 20]), obstacles=squares), groups, params)}


def _judge_menge_4square(out: dict[str, Outcome]) -> tuple[str, str, bool]:
    r = out["4square"]
    goals = -r.traj.positions[0]
    far = np.linalg.norm(r.traj.positions[-1] - goals, axis=1)
    last = _last_reach_s(r)
    measured = f"arrived {_arrived(r):.0%}" + (f", the last at {last:.0f} s" if last is not None else
                                               f"; the farthest {far.max():.1f} m from its goal at {_duration_s(r):.0f} s")
    return (f"all 100 within 0.05 m of their mirrored start (goal_reached) within Menge's {MENGE_DURATION_S:.0f} s",
            measured, _arrived(r) == 1.0 and last is not None and last <= MENGE_DURATION_S)


def _last_reach_s(r: Outcome) -> float | None:
    """When the last agent arrived (arrivals staying): the run stops then."""
    return float(_duration_s(r)) if _arrived(r) == 1.0 else None


# ---- SteerSuite test cases (SteerSuite/Release, testcases/*.xml) ----------------------------
# Every agent: radius 0.5 m, desiredSpeed 1.3 m/s, one seekStaticTarget with timeDuration
# 1000 s; world bounds x, z in [-100, 100]. An agent whose last goal is reached is disabled
# and leaves the world. The test cases leave "reached" to the steering module: SteerSuite's
# reference agent (simpleAI/src/SimpleAgent.cpp: "if the agent's distance to its goal is
# less than its radius") and its PPR agent (PED_REACHED_TARGET_DISTANCE_THRESHOLD 0.5) count
# 0.5 m, its RVO and social-forces plugins 2.5 radii (1.25 m). The cases take the strict
# reading, the body's radius: no looser than any of SteerSuite's agents. The test cases set
# no time step (SteerSuite's engine runs at 20 fps by default); the RVO method runs at its
# default step here. Criterion: everyone reaches its target within the goal's timeDuration
# of 1000 s.
STEER_RADIUS = 0.5
STEER_SPEED = 1.3
STEER_REACHED_M = STEER_RADIUS
STEER_LIMIT_S = 1000.0
STEER_BOUNDS = ([-100, -100], [100, 100])


def _steer_params(**more) -> dict:
    return {"remove_on_arrival": True, "arrival_radius": STEER_REACHED_M,
            "max_steps": int(round(STEER_LIMIT_S / 0.25)), **more}


def _steer_group(name: str, count: int, spawn, goal) -> Group:
    return Group(name, count, spawn=spawn, goal=goal, radius=STEER_RADIUS, max_speed=1.5, pref_speed=STEER_SPEED)


def _box(xmin, xmax, zmin, zmax) -> Box:
    """A SteerSuite <obstacle> (x and z extents)."""
    return Box([xmin, zmin], [xmax, zmax])


def _steer_hallway_two_way(method: str) -> dict[str, Setup]:
    # testcases/hallway-two-way.xml: walls z >= 8.01 and z <= -8 along the whole world;
    # two regions of 100 agents, both spread over x -97..70, z -7..7; targets (98, 5) and (-98, -4)
    scene = Scene(bounds=STEER_BOUNDS, obstacles=[_box(-100, 100, 8.01, 100), _box(-100, 100, -100, -8)])
    region = Rect([-97, -7], [70, 7])
    return {"hallway": Setup(scene, [_steer_group("east", 100, region, [98, 5]),
                                     _steer_group("west", 100, region, [-98, -4])], _steer_params())}


def _steer_bottleneck_squeeze(method: str) -> dict[str, Setup]:
    # testcases/bottleneck-squeeze.xml: a 4.2 m wide, 31 m long passage (walls x -11..20 beyond
    # z = ±2.1); 1000 agents in x 23..90, z -40..40 bound for the one point (-90, 0)
    scene = Scene(bounds=STEER_BOUNDS, obstacles=[_box(-11, 20, 2.1, 100), _box(-11, 20, -100, -2.1)])
    return {"squeeze": Setup(scene, [_steer_group("crowd", 1000, Rect([23, -40], [90, 40]), [-90, 0])],
                             _steer_params())}


def _steer_oncoming_groups(method: str) -> dict[str, Setup]:
    # testcases/oncoming-groups.xml: six agents round (0, 0) bound for (0, 40), six round
    # (0, 15) bound for (0, -40), in the open
    north = Points([[0, 0], [1.5, -1.3], [-2, 0], [-1, -1], [1.3, 1], [-1.4, 1.4]])
    south = Points([[0, 15], [1.5, 13.7], [-2, 15], [-1, 14], [1.3, 16], [-1.4, 16.4]])
    return {"groups": Setup(Scene(bounds=STEER_BOUNDS), [_steer_group("north", 6, north, [0, 40]),
                                                         _steer_group("south", 6, south, [0, -40])], _steer_params())}


def _steer_curves(method: str) -> dict[str, Setup]:
    # testcases/curves.xml: one agent from (-1, -3) to (0, 13) through an S of six wall boxes
    scene = Scene(bounds=STEER_BOUNDS, obstacles=[
        _box(-100, 2.1, -1.99, 0), _box(-100, 4.1, 0.01, 2), _box(-100, 2.1, 2.001, 4),
        _box(-2.1, 100, 6.01, 8), _box(-4.1, 100, 8.01, 10), _box(-2.1, 100, 10.001, 12)])
    return {"curves": Setup(scene, [_steer_group("A", 1, [-1, -3], [0, 13])], _steer_params())}


def _steer_doorway_two_way(method: str) -> dict[str, Setup]:
    # testcases/doorway-two-way.xml: a corridor (walls x -20..20 at z 3.1..5 and -3..-1) cut
    # by a wall at x -0.2..0 with a 1.6 m door (z -0.3..1.3); A (-10, 1) -> (15, 1), B the reverse
    scene = Scene(bounds=STEER_BOUNDS, obstacles=[
        _box(-20, 20, 3.1, 5), _box(-20, 20, -3, -1), _box(-0.2, 0, -3, -0.3), _box(-0.2, 0, 1.3, 5)])
    return {"doorway": Setup(scene, [_steer_group("A", 1, [-10, 1], [15, 1]), _steer_group("B", 1, [10, 1], [-15, 1])],
                             _steer_params())}


def _judge_steer(name: str, n: int):
    def judge(out: dict[str, Outcome]) -> tuple[str, str, bool]:
        r = out[name]
        last = _last_arrival_s(r)
        t = r.summary.get("mean_time_to_goal_s")
        measured = f"arrived {_arrived(r):.1%} of {n}" + (f", mean {t:.0f} s" if t is not None else "") + (
            f", the last at {last:.0f} s" if last is not None else f" in {_duration_s(r):.0f} s")
        who = "the agent reaches its" if n == 1 else f"all {n} reach their"
        return (f"{who} target (within {STEER_REACHED_M:g} m, then removed) within the goal's "
                f"timeDuration of {STEER_LIMIT_S:.0f} s", measured,
                bool(_arrived(r) == 1.0 and last is not None and last <= STEER_LIMIT_S))
    return judge


CASES: list[Case] = [
    Case("rvo2_circle", "RVO2 example Circle (examples/Circle.cc)",
         "250 agents of radius 1.5 m on a 200 m circle swap to their antipodes and stay", ("rvo",),
         _rvo2_circle, _judge_rvo2_circle),
    Case("rvo2_roadmap", "RVO2 example Roadmap (examples/Roadmap.cc)",
         "4 x 25 agents of radius 2 m cross past four blocks to one goal vertex per corner (our guidance field "
         "replaces the roadmap)", ("rvo",), _rvo2_roadmap, _judge_rvo2_roadmap),
    Case("menge_4square", "Menge example 4square (examples/core/4square)",
         "four 5 x 5 groups swap corners through the cross between four squares (one group larger and slower)",
         ("rvo",), _menge_4square, _judge_menge_4square),
    Case("steersuite_hallway_two_way", "SteerSuite testcases/hallway-two-way.xml",
         "100 + 100 agents spread along a 16 m hallway walk to its two ends", ("rvo",), _steer_hallway_two_way,
         _judge_steer("hallway", 200)),
    Case("steersuite_bottleneck_squeeze", "SteerSuite testcases/bottleneck-squeeze.xml",
         "1000 agents through a 4.2 m x 31 m passage to one point", ("rvo",), _steer_bottleneck_squeeze,
         _judge_steer("squeeze", 1000)),
    Case("steersuite_oncoming_groups", "SteerSuite testcases/oncoming-groups.xml",
         "two groups of six walk through each other in the open", ("rvo",), _steer_oncoming_groups,
         _judge_steer("groups", 12), quick=True),
    Case("steersuite_curves", "SteerSuite testcases/curves.xml",
         "one agent follows an S-shaped passage", ("rvo",), _steer_curves, _judge_steer("curves", 1)),
    Case("steersuite_doorway_two_way", "SteerSuite testcases/doorway-two-way.xml",
         "two agents pass each other through a 1.6 m door in a corridor", ("rvo",), _steer_doorway_two_way,
         _judge_steer("doorway", 2)),
]
