"""Continuous-time audit against closed-form cases: overlaps between frames are found."""

import numpy as np
import pytest

from crowdmotion import Box, Circle, Polygon, Scene, Sphere, Trajectories
from crowdmotion.metrics import collision_audit, path_length


def two_frames(a0, a1, b0=None, b1=None, radius=0.5):
    pts = [[a0], [a1]] if b0 is None else [[a0, b0], [a1, b1]]
    return Trajectories(np.array(pts, dtype=float), dt=1.0, radius=radius)


def test_agents_crossing_between_frames_are_caught():
    # frames show them 10 m apart; at t = 0.5 s they are at the same point
    tr = two_frames([-5, 0], [5, 0], [5, 0], [-5, 0])
    rep = collision_audit(tr)
    assert rep.agent_agent == 1
    assert rep.worst_agent_agent == pytest.approx(1.0)
    assert rep.events[0].time == pytest.approx(0.5)


def test_parallel_agents_two_radii_apart_do_not_overlap():
    tr = two_frames([0, 0], [5, 0], [0, 1.0], [5, 1.0])
    assert collision_audit(tr).agent_agent == 0
    tr = two_frames([0, 0], [5, 0], [0, 0.9], [5, 0.9])
    assert collision_audit(tr).worst_agent_agent == pytest.approx(0.1)


def test_inactive_agents_are_ignored():
    tr = two_frames([-5, 0], [5, 0], [5, 0], [-5, 0])
    tr.active = np.array([[True, True], [True, False]])
    assert collision_audit(tr).agent_agent == 0


@pytest.mark.parametrize("ob,depth", [
    (Circle([0, 0.3], 1.0), 0.8),            # passes 0.3 from the centre: 1 - 0.3 + 0.1 radius
    (Box([-1, 0.3], [1, 2]), 0.1 - 0.3 + 0.0),  # box 0.3 above the path, agent radius 0.1 -> clear
    (Polygon([[-1, -0.05], [1, -0.05], [0, 2]]), None),  # path runs through the triangle
])
def test_segment_through_obstacle_between_frames(ob, depth):
    tr = two_frames([-5, 0], [5, 0], radius=0.1)
    rep = collision_audit(tr, Scene(([-10, -10], [10, 10]), [ob]))
    if depth is not None and depth <= 0:
        assert rep.agent_obstacle == 0
    else:
        assert rep.agent_obstacle == 1
        if depth is not None:
            assert rep.worst_agent_obstacle == pytest.approx(depth, abs=1e-6)


def test_box_corner_clearance_is_exact():
    # the line x + y = 3 passes the box corner (1, 1) at sqrt(0.5); radius 0.8 overlaps by 0.8 - 0.7071
    tr = two_frames([3, 0], [0, 3], radius=0.8)
    rep = collision_audit(tr, Scene(([-10, -10], [10, 10]), [Box([-1, -1], [1, 1])]))
    assert rep.agent_obstacle == 1
    assert rep.worst_agent_obstacle == pytest.approx(0.8 - np.sqrt(0.5), abs=1e-9)


def test_a_body_reaching_past_the_scene_s_edge_enters_its_wall():
    # the bounds are walls: a body of radius 0.5 whose centre comes within 0.2 m of x = 10
    # reaches 0.3 m past it (obstacle -1); one clamped against the edge touches it only
    tr = two_frames([5, 0], [9.8, 0])
    rep = collision_audit(tr, Scene(([-10, -10], [10, 10])))
    assert rep.agent_obstacle == 1 and rep.worst_agent_obstacle == pytest.approx(0.3)
    assert rep.events[0].b == -1 and rep.events[0].position == pytest.approx((9.8, 0.0))
    assert collision_audit(two_frames([5, 0], [9.5, -9.5]), Scene(([-10, -10], [10, 10]))).agent_obstacle == 0
    assert collision_audit(tr).agent_obstacle == 0  # no scene: no walls


def test_moving_obstacle_hits_a_standing_agent():
    ob = Sphere([0, 0, 0], 1.0, path=([0, 1], [[-5, 0, 0], [5, 0, 0]]))
    tr = two_frames([0, 0.5, 0], [0, 0.5, 0], radius=0.25)
    rep = collision_audit(tr, Scene(([-10] * 3, [10] * 3), [ob]))
    assert rep.agent_obstacle == 1
    assert rep.worst_agent_obstacle == pytest.approx(0.75)


def _all_pairs_overlaps(pos, active, radius):
    """Every (frame, i, j, depth) overlap by brute force over all pairs: the closest
    approach of two linear motions minimised on a fine grid of t, then the exact t*."""
    found = []
    for f in range(len(pos) - 1):
        for i in range(pos.shape[1]):
            for j in range(i + 1, pos.shape[1]):
                if not (active[f, i] and active[f + 1, i] and active[f, j] and active[f + 1, j]):
                    continue
                w0, dw = pos[f, i] - pos[f, j], (pos[f + 1, i] - pos[f, i]) - (pos[f + 1, j] - pos[f, j])
                t = np.clip(-(w0 @ dw) / (dw @ dw), 0, 1) if dw @ dw > 0 else 0.0
                ts = np.r_[np.linspace(0, 1, 201), t]
                depth = radius[i] + radius[j] - np.linalg.norm(w0 + ts[:, None] * dw, axis=1).min()
                if depth > 0:
                    found.append((f, i, j, depth))
    return found


@pytest.mark.parametrize("dim", [2, 3])
def test_every_overlap_of_a_dense_random_crowd_is_found_as_brute_force_finds_it(dim):
    # 60 agents of mixed sizes milling in a 6 m box (some leave and come back), against
    # every pair checked directly: the pair search misses none and invents none
    rng = np.random.default_rng(7)
    steps = rng.normal(0, 0.25, (12, 60, dim))
    pos = np.cumsum(np.concatenate([rng.uniform(0, 6, (1, 60, dim)), steps]), axis=0)
    radius = rng.uniform(0.1, 0.4, 60)
    tr = Trajectories(pos, dt=0.5, radius=radius)
    tr.active = rng.random((13, 60)) > 0.1
    want = _all_pairs_overlaps(pos, tr.active, radius)
    rep = collision_audit(tr, max_events=10_000)
    assert len(want) > 50 and rep.agent_agent == len(want)
    got = {(e.frame, e.a, e.b): e.penetration for e in rep.events}
    assert got.keys() == {(f, i, j) for f, i, j, _ in want}
    assert all(got[(f, i, j)] == pytest.approx(d, abs=1e-12) for f, i, j, d in want)
    # only the intervals asked for, the deepest first within each, at most max_events
    some = np.zeros(12, dtype=bool)
    some[[2, 7]] = True
    rep = collision_audit(tr, intervals=some, max_events=5)
    assert rep.agent_agent == sum(f in (2, 7) for f, *_ in want) and len(rep.events) == 5
    first = [d for frame in (2, 7) for d in sorted((d for f, i, j, d in want if f == frame), reverse=True)][:5]
    assert [e.penetration for e in rep.events] == pytest.approx(first)


def test_path_length_counts_active_steps():
    tr = Trajectories(np.array([[[0, 0]], [[3, 4]], [[3, 4]]], float), dt=1.0)
    assert path_length(tr)[0] == pytest.approx(5.0)


# ---- per-group behaviour report -------------------------------------------------------------
def _walk(starts, velocity, frames=11, dt=0.5, group=None):
    from crowdmotion.trajectories import Trajectories

    t = np.arange(frames)[:, None, None] * dt
    pos = np.asarray(starts, float)[None] + t * np.asarray(velocity, float)
    return Trajectories(pos, dt, group=group)


def test_group_report_straight_parallel_walkers():
    from crowdmotion.metrics import group_report

    rep = group_report(_walk([[0, 0], [0, 2]], [[1.0, 0.0], [1.0, 0.0]]))["agents"]
    assert rep["lateral_spread_m"] == pytest.approx(1.0)  # std of {0, 2}
    assert rep["lateral_deviation_m"] == pytest.approx(0.0)
    assert rep["heading_change_rate_rad_s"] == pytest.approx(0.0)
    assert rep["mean_speed_mps"] == pytest.approx(1.0)
    assert rep["path_length_ratio"] == pytest.approx(1.0)
    assert rep["time_to_goal_s"] is None  # nobody left the scene


def test_group_report_zigzag_turn_rate_and_deviation():
    from crowdmotion.metrics import group_report
    from crowdmotion.trajectories import Trajectories

    # alternate 45° up and 45° down: every frame turns by 90°, and the path swings 0.5 m
    steps = np.array([[0.5, 0.5] if k % 2 == 0 else [0.5, -0.5] for k in range(10)])
    pos = np.concatenate([[[0.0, 0.0]], np.cumsum(steps, axis=0)])[:, None, :]
    rep = group_report(Trajectories(pos, 0.5))["agents"]
    assert rep["heading_change_rate_rad_s"] == pytest.approx((np.pi / 2) / 0.5)
    assert rep["lateral_deviation_m"] == pytest.approx(0.5)
    assert rep["path_length_ratio"] == pytest.approx(np.sqrt(2.0))  # 10 diagonal steps over 5 m


def test_group_report_mixing_counts_other_group_neighbours():
    from crowdmotion.metrics import group_report

    # A at (0,0), (1,0); B at (0,1): A0 sees A1 and B0, A1 sees A0 and B0, B0 sees only A
    traj = _walk([[0, 0], [1, 0], [0, 1]], [[0.1, 0]] * 3, frames=3, group=["A", "A", "B"])
    rep = group_report(traj)
    assert rep["A"]["mixing_index"] == pytest.approx(0.5)
    assert rep["B"]["mixing_index"] == pytest.approx(1.0)
    assert rep["A"]["same_group_neighbors"] == pytest.approx(1.0)
    assert rep["B"]["same_group_neighbors"] == pytest.approx(0.0)


def test_group_report_sees_crowded_agents_walk_slower():
    from crowdmotion.metrics import group_report

    rng = np.random.default_rng(0)
    dense = rng.uniform(0, 3, size=(30, 2))
    sparse = np.c_[np.linspace(50, 200, 10), np.zeros(10)]
    starts = np.concatenate([dense, sparse])
    vel = np.concatenate([np.full((30, 2), [0.3, 0.0]), np.full((10, 2), [1.5, 0.0])])
    rep = group_report(_walk(starts, vel))["agents"]
    assert rep["speed_density_slope"] < 0
    speeds = [row["mean_speed_mps"] for row in rep["speed_by_density"]]
    assert speeds[0] == pytest.approx(1.5) and speeds[-1] == pytest.approx(0.3)


def test_group_report_reads_a_crowd_in_a_corridor_as_dense_as_it_is():
    from crowdmotion.metrics import group_report

    # a lattice of 0.6 m (2.78 persons/m²) filling a corridor 4.2 m wide, walking along it
    xs, ys = np.meshgrid(np.arange(0.3, 40.0, 0.6), np.arange(0.3, 4.2, 0.6), indexing="ij")
    starts = np.c_[xs.ravel(), ys.ravel()]
    inner = (starts[:, 0] > 5) & (starts[:, 0] < 35)  # away from the crowd's ends
    group = np.where(inner, "inner", "ends")
    walk = _walk(starts, np.tile([0.1, 0.0], (len(starts), 1)), group=group)
    walls = Scene(bounds=([0, 0], [41, 4.2]))
    rows = group_report(walk, walls)["inner"]["speed_by_density"]
    # over the walkable part of each 2 m disc every agent, the ones along the walls too, reads over 2 /m²
    assert [r["density_min"] for r in rows] == [2.0]
    # the disc's whole area (no scene) puts those along the walls near half of it
    rows = group_report(walk)["inner"]["speed_by_density"]
    assert min(r["density_min"] for r in rows) <= 1.0
    # the scene stored with the trajectories serves as well as one given
    walk.metadata["scene"] = walls.to_dict()
    assert group_report(walk)["inner"]["speed_by_density"] == group_report(walk, walls)["inner"]["speed_by_density"]


def test_diversity_measures_runs_apart_at_the_same_frame():
    from crowdmotion.metrics import diversity

    base = np.zeros((4, 2, 2))
    base[:, 1, 0] = np.arange(4)  # agent 1 walks east
    other = base.copy()
    other[2:, 0] += [3.0, 4.0]  # agent 0 is 5 m off from frame 2 on
    a, b = Trajectories(base, 0.5), Trajectories(other, 0.5)
    d = diversity([a, b])
    assert d["pairs"] == 1
    assert d["mean_distance_m"] == pytest.approx(2 * 5.0 / 8)  # two agent-frames of 5 m out of eight
    assert d["max_distance_m"] == pytest.approx(5.0)
    assert d["share_apart"] == pytest.approx(2 / 8)
    assert d["first_apart_s"] == pytest.approx(1.0)
    assert d["by_frame_m"] == pytest.approx([0, 0, 2.5, 2.5])
    assert diversity([a, a, a])["share_apart"] == 0.0 and diversity([a, a])["first_apart_s"] is None
    with pytest.raises(ValueError, match="at least two runs"):
        diversity([a])
    with pytest.raises(ValueError, match="agent counts differ"):
        diversity([a, Trajectories(base[:, :1], 0.5)])


def test_cluster_size_and_count_while_groups_meet():
    from crowdmotion.metrics import group_report

    # group a: three agents chained 1 m apart and one alone; group b: two agents 3 m away
    a = [[0, 0], [1, 0], [2, 0], [0, 3]]
    b = [[2, 3.5], [4, 3.5]]
    pos = np.repeat(np.array([a + b], float), 3, axis=0)
    pos[:, :, 0] += np.arange(3)[:, None] * 0.1  # all walk east together
    traj = Trajectories(pos, 0.5, group=np.array(["a"] * 4 + ["b"] * 2, object))
    rep = group_report(traj)
    assert rep["a"]["cluster_size"] == pytest.approx((3 + 3 + 3 + 1) / 4)
    assert rep["a"]["clusters"] == pytest.approx(1.0)
    assert rep["b"]["cluster_size"] == pytest.approx(1.0) and rep["b"]["clusters"] == 0.0  # 2 m apart: not linked
    far = pos.copy()
    far[:, 4:, 1] += 50  # no meeting: no clusters measured
    assert group_report(Trajectories(far, 0.5, group=traj.group))["a"]["cluster_size"] is None


def test_root_motion_of_a_steady_circle_walk_is_its_closed_form():
    from crowdmotion.metrics import root_motion

    # 1 m/s round a circle of 2 m, sampled at 24 fps: a = v²/r = 0.5 m/s², turning v/r = 0.5 rad/s,
    # and the mean of the 25 frames round each (±0.5 s) lies r (1 - D) inside the path, D the
    # Dirichlet kernel sin(25 θ / 2) / (25 sin(θ / 2)) of the turn per frame θ = 0.5 / 24 rad
    t = np.arange(240) / 24.0
    p = np.stack([np.c_[2 * np.cos(0.5 * t), 2 * np.sin(0.5 * t)]], axis=1)
    m = root_motion(Trajectories(p, 1 / 24.0, radius=np.array([0.2])))
    assert m["acceleration_mps2"]["p95"] == pytest.approx(0.5, rel=0.01)
    assert m["turn_rate_rad_s"]["p95"] == pytest.approx(0.5, rel=0.01)
    th = 0.5 / 24
    assert m["deviation_from_1s_average_m"]["p95"] == pytest.approx(2 * (1 - np.sin(12.5 * th) / (25 * np.sin(th / 2))),
                                                                    rel=0.01)


def test_root_motion_judges_the_frames_a_dcc_plays_and_ignores_standing():
    from crowdmotion.metrics import root_motion

    # a straight walk at 0.25 s steps: nothing to see at 24 fps; a right-angle turn shows,
    # rounded by the B-spline the export plays
    t = np.arange(40) * 0.25
    straight = np.c_[1.2 * t, np.zeros_like(t)]
    turned = np.where(t[:, None] < 5, straight, np.c_[np.full_like(t, 6.0), 1.2 * (t - 5)])
    standing = np.zeros((40, 2))
    m = root_motion(Trajectories(np.stack([straight], axis=1), 0.25, radius=np.array([0.2])))
    assert m["acceleration_mps2"]["max"] < 1e-9 and m["turn_rate_rad_s"]["max"] == 0.0
    m = root_motion(Trajectories(np.stack([turned, standing], axis=1), 0.25, radius=np.full(2, 0.2)))
    # at the corner the spline's acceleration peaks at the step's change of velocity / dt
    # (a tent 2 steps wide: a central difference over ±1/24 s sees 1 - (1/24)/(3 dt) of it),
    # perpendicular to the velocity there, the mean of the two moves: turn rate |a| / |v|
    peak = 1.2 * np.sqrt(2) / 0.25
    assert m["acceleration_mps2"]["max"] == pytest.approx(peak * (1 - (1 / 24) / (3 * 0.25)), rel=0.01)
    assert m["turn_rate_rad_s"]["max"] == pytest.approx(peak / (1.2 / np.sqrt(2)), rel=0.1)


def test_group_report_time_to_goal_counts_from_entering():
    from crowdmotion.metrics import group_report
    from crowdmotion.trajectories import Trajectories

    # two walkers of one group: one there from the start leaves after frame 6, one enters
    # at frame 4 and leaves after frame 12 (frames 0.5 s apart): 3 s and 4 s from entering
    # (counted from t = 0, the second would take 6 s)
    pos = np.zeros((16, 2, 2))
    pos[:, 0, 0] = np.minimum(np.arange(16), 6) * 0.5
    pos[:, 1, 0] = np.clip(np.arange(16) - 4, 0, 8) * 0.5
    pos[:, 1, 1] = 1.0
    active = np.zeros((16, 2), dtype=bool)
    active[0:7, 0] = True
    active[4:13, 1] = True
    rep = group_report(Trajectories(pos, 0.5, group=np.array(["g", "g"]), active=active))["g"]
    assert rep["time_to_goal_s"] == pytest.approx(3.5)


def test_a_formation_run_at_its_step_limit_unrecovered_says_so_in_its_line():
    from crowdmotion.metrics import headline, note_step_limit

    summary = {"agents": 24, "frames": 10, "agent_agent_overlaps": 0, "agent_obstacle_penetrations": 0,
               "formation": {"band": {"recovered_s": None, "edge_length_error_mean": 0.131}}}
    note_step_limit(summary, "formation.max_steps", 1500, True, 150.0, short=True)
    assert summary["ended_at_limit"] == {"setting": "formation.max_steps", "value": 1500, "simulated_s": 150.0}
    assert "the run stopped at formation.max_steps = 1500, 150 s simulated" in headline(summary)
    done = {k: v for k, v in summary.items() if k != "ended_at_limit"}
    note_step_limit(done, "formation.max_steps", 1500, True, 150.0, short=False)  # recovered: nothing to say
    assert "ended_at_limit" not in done


def test_a_run_at_its_step_limit_behind_people_whose_route_never_leaves_names_that_not_the_setting():
    from crowdmotion.metrics import headline, note_step_limit

    summary = {"agents": 40, "frames": 10, "agent_agent_overlaps": 0, "agent_obstacle_penetrations": 0,
               "arrival_rate": 0.8, "journeys": {"finished": 40, "standing_at_end": 32}}
    note_step_limit(summary, "rvo.max_steps", 2000, True, 500.0)
    line = headline(summary)
    assert "32 finished a route that does not leave" in line and "end the route with a leave stage" in line
    summary["journeys"]["standing_at_end"] = 0  # everyone done left: only the setting is to blame
    assert "raise it to let them arrive" in headline(summary)


def test_agents_short_of_their_goal_that_came_no_nearer_in_the_last_quarter_count_as_stalled():
    from crowdmotion.metrics import headline, note_step_limit, stalled_short

    t = np.arange(20.0)
    stuck = np.stack([np.full(20, 5.0), np.zeros(20)], axis=1)  # against a wall 5 m short, for good
    walking = np.stack([t * 0.5, np.ones(20)], axis=1)  # still on its way, 0.5 m a frame
    there = np.stack([np.full(20, 10.0), np.full(20, 2.0)], axis=1)  # arrived
    traj = Trajectories(np.stack([stuck, walking, there], axis=1), 1.0)
    goals = np.array([[10.0, 0.0], [30.0, 1.0], [10.0, 2.0]])
    assert stalled_short(traj, goals, np.array([False, False, True])) == 1
    summary = {"agents": 3, "frames": 20, "agent_agent_overlaps": 0, "agent_obstacle_penetrations": 0,
               "arrival_rate": 1 / 3}
    note_step_limit(summary, "pso.iterations", 19, True, 19.0, stalled=1)
    assert "with 1 short of their goal that came no nearer it in the run's last quarter" in headline(summary)
