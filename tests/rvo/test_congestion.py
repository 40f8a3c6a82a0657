"""Congestion-aware guidance: the field re-solved with density-weighted costs."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion.groups import Rect
from crowdmotion.rvo.congestion import KEEP_RIGHT_M, CongestionRouter
from crowdmotion.routing import distance_fields


def _fields():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([8, 2], [10, 10]), cm.Circle([15, 4], 1.5)])
    return distance_fields(scene, [Rect([18, 8], [19.5, 9.5])], 0.3, 0.25)


def _random_weights(router, seed=0):
    """The router's graph with random cell costs and random flux against each edge."""
    g = router.graph
    rng = np.random.default_rng(seed)
    cost = 1.0 + 3.0 * rng.random(len(g.cell_index))
    return g.weighted(cost, (rng.random(len(g.src)), rng.random(len(g.src))))


def test_the_weighted_fields_are_scipys_dijkstra_on_the_same_directed_graph():
    from scipy.sparse.csgraph import dijkstra
    f = _fields()
    router = CongestionRouter(f, 1.0, 20.0)
    g = router.graph
    w = _random_weights(router)
    ours = g.distances_on(w, f.goal_cells, f.blocked.shape)[0]
    goals = np.asarray(f.goal_cells[0]).reshape(-1, 2)
    theirs = np.full(f.blocked.shape, np.inf)
    theirs.ravel()[g.cell_index] = dijkstra(g.csr(w), directed=True, indices=g.node[goals[:, 0], goals[:, 1]],
                                           min_only=True)
    np.testing.assert_array_equal(ours, theirs)


def test_a_field_solved_near_some_points_has_the_whole_searchs_distances_there_and_stops_short():
    f = _fields()
    router = CongestionRouter(f, 1.0, 20.0)
    w = _random_weights(router, 1)
    whole = router.graph.distances_on(w, f.goal_cells, f.blocked.shape)[0]
    near = router.near(np.array([[12.0, 7.0], [16.0, 8.0]]), 1.0)
    part = router.graph.distances_on(w, f.goal_cells, f.blocked.shape, [near])[0]
    solved = np.isfinite(part)
    np.testing.assert_array_equal(part[solved], whole[solved])
    assert np.all(solved[near & np.isfinite(whole)]), "every cell asked for and reachable is solved"
    assert np.isfinite(whole).sum() > 2 * solved.sum(), "the far side of the wall is left"
    assert near.sum() == 2 * (2 * 4 + 1) ** 2  # 1 m at 0.25 m cells: 4 cells each way round each point


def test_a_search_cut_into_slices_gives_the_whole_searchs_distances():
    f = _fields()
    router = CongestionRouter(f, 1.0, 20.0)
    w = _random_weights(router, 2)
    near = router.near(np.array([[12.0, 7.0]]), 3.0)
    for mask in (None, near):
        whole = router.graph.distances_on(w, f.goal_cells, f.blocked.shape, None if mask is None else [mask])[0]
        search = router.searches(np.array([0]), w, None if mask is None else [mask])[0]
        slices = 0
        while not search.advance(37):
            slices += 1
        assert slices > 3, "the search took several slices"
        assert search.settled <= 37 * (slices + 1)
        np.testing.assert_array_equal(search.distances(), whole)


def test_with_nobody_about_the_re_solved_field_is_the_exact_one():
    f = _fields()
    d = CongestionRouter(f, 1.0).resolve(np.array([[-50.0, -50.0]]), f.dist)
    finite = np.isfinite(f.dist)
    assert np.array_equal(np.isfinite(d), finite)
    np.testing.assert_allclose(d[finite], f.dist[finite], atol=1e-9)


def test_a_crowd_makes_its_side_of_a_corridor_dearer():
    scene = cm.Scene(bounds=([0, 0], [30, 4]))
    f = distance_fields(scene, [Rect([29, 0.5], [29.8, 3.5])], 0.25, 0.25)
    crowd = np.stack(np.meshgrid(np.linspace(10, 20, 25), np.linspace(0.5, 1.5, 4)), -1).reshape(-1, 2)
    d = CongestionRouter(f, 1.0).resolve(crowd, f.dist)[0]
    row = int(5 / 0.25)  # x = 5 m, before the crowd
    low, high = d[row, int(1.0 / 0.25)], d[row, int(3.0 / 0.25)]
    assert f.dist[0, row, 4] == f.dist[0, row, 12], "the exact field does not care"
    assert low > high, "the way past the crowd's side costs more"


def test_congestion_zero_keeps_the_exact_field():
    f = _fields()
    router = CongestionRouter(f, 0.0)
    assert not router.enabled
    assert router.resolve(np.array([[5.0, 5.0]]), f.dist) is f.dist


def _stream(y0: float, y1: float, vx: float):
    """Positions and velocities of a stream walking along x at ``vx`` between y0 and y1."""
    pos = np.stack(np.meshgrid(np.linspace(10, 20, 15), np.linspace(y0, y1, 3)), -1).reshape(-1, 2)
    return pos, np.tile([vx, 0.0], (len(pos), 1))


def test_an_agent_is_led_along_the_side_its_own_stream_walks_on():
    # two equally dense streams share a corridor: west-bound in the north half, east-bound
    # in the south half; for an agent bound east, density alone cannot tell the halves
    # apart, the oncoming flux makes the north half dearer
    scene = cm.Scene(bounds=([0, 0], [30, 4]))
    f = distance_fields(scene, [Rect([29, 0.5], [29.8, 3.5])], 0.25, 0.25)
    north, vn = _stream(2.375, 3.375, -1.0)  # cell centres mirrored across the corridor's middle
    south, vs = _stream(0.625, 1.625, 1.0)
    pos, vel = np.vstack([north, south]), np.vstack([vn, vs])
    row, s_col, n_col = int(12 / 0.25), 4, 11  # x = 12 m, inside both streams; cells mirrored (y 1.125, 2.875 m)
    density_only = CongestionRouter(f, 1.0, 0.0).resolve(pos, f.dist, vel)[0]
    counter = CongestionRouter(f, 1.0, 20.0).resolve(pos, f.dist, vel)[0]
    assert abs(density_only[row, n_col] - density_only[row, s_col]) < 0.05
    assert counter[row, n_col] - counter[row, s_col] > 1.0
    with_it = CongestionRouter(f, 1.0, 20.0).resolve(north, f.dist, -vn)[0]  # a stream going our way
    np.testing.assert_allclose(with_it, CongestionRouter(f, 1.0, 0.0).resolve(north, f.dist)[0], rtol=0.01)


def test_a_stream_over_the_whole_width_leads_a_walker_to_its_own_right_of_it():
    # the west-bound stream fills the corridor's width, mirrored across its middle: read at
    # the move, an east-bound walker finds neither half dearer; read a step to its right
    # (keep right, the default), the north half (its left) is the dearer one
    scene = cm.Scene(bounds=([0, 0], [30, 4]))
    f = distance_fields(scene, [Rect([29, 0.5], [29.8, 3.5])], 0.25, 0.25)
    (south, vs), (north, vn) = _stream(0.625, 1.625, -1.0), _stream(2.375, 3.375, -1.0)
    pos, vel = np.vstack([south, north]), np.vstack([vs, vn])
    row, s_col, n_col = int(12 / 0.25), 4, 11  # x = 12 m; cells mirrored (y 1.125, 2.875 m)
    at_move = CongestionRouter(f, 1.0, 20.0, keep_right=False).resolve(pos, f.dist, vel)[0]
    kept = CongestionRouter(f, 1.0, 20.0).resolve(pos, f.dist, vel)[0]
    assert abs(at_move[row, n_col] - at_move[row, s_col]) < 0.05
    assert kept[row, n_col] - kept[row, s_col] > 1.0
    # and for a walker bound west, the stream bound east: the south half is its left
    back = distance_fields(scene, [Rect([0.2, 0.5], [1.0, 3.5])], 0.25, 0.25)
    mirrored = CongestionRouter(back, 1.0, 20.0).resolve(pos, back.dist, -vel)[0]
    assert mirrored[row, s_col] - mirrored[row, n_col] > 1.0
    # KEEP_RIGHT_M (0.3 m) to the right of a move along +x on 0.25 m cells: one cell lower in y
    g = CongestionRouter(f, 1.0, 20.0).graph
    src_right, _, src_left, _ = g.beside(KEEP_RIGHT_M)
    cell = g.cell_index[g.src]
    along_x = (g.unit[:, 0] == 1) & (g.unit[:, 1] == 0) & (cell % f.blocked.shape[1] == 8)  # y 2.0-2.25 m
    assert along_x.any()
    np.testing.assert_array_equal(src_right[along_x], cell[along_x] - 1)
    np.testing.assert_array_equal(src_left[along_x], cell[along_x] + 1)


def test_two_streams_reaching_a_passage_at_once_pass_on_their_right():
    # the built-in blocked street at seed 0: read at the move, the two fronts met across
    # the 3.5 m side passage and stood (4 of 60 home in 375 s)
    from crowdmotion.builtin import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    path = next(p for p in builtin_scenarios() if p.stem == "rvo_blocked_street")
    summary = run_scenario(load_scenario(path), seed=0, progress=False).summary
    assert summary["arrival_rate"] == 1.0 and summary["agent_agent_overlaps"] == 0
    assert summary["mean_time_to_goal_s"] < 60.0


def test_a_stream_crossing_at_right_angles_costs_nothing_extra():
    f = _fields()
    pos = np.stack(np.meshgrid(np.linspace(2, 6, 9), np.linspace(2, 8, 9)), -1).reshape(-1, 2)
    vel = np.tile([0.0, 1.0], (len(pos), 1))
    router = CongestionRouter(f, 1.0, 20.0)
    assert router.graph.unit.shape[1] == 2
    fwd, back = router.against(pos, vel)
    horizontal = router.graph.unit[:, 1] == 0
    assert np.all(fwd[horizontal] == 0) and np.all(back[horizontal] == 0)
    assert fwd[~horizontal].max() > 0 or back[~horizontal].max() > 0


def test_the_directed_field_with_no_flux_is_the_undirected_one():
    f = _fields()
    router = CongestionRouter(f, 1.0, 20.0)
    crowd = np.array([[4.0, 4.0], [4.5, 4.2], [12.0, 1.0]])
    still = router.resolve(crowd, f.dist, np.zeros_like(crowd))
    np.testing.assert_allclose(still, CongestionRouter(f, 1.0, 0.0).resolve(crowd, f.dist), atol=1e-9)


def _bot_counterflow(counterflow: float):
    """60 walkers from each end of the FZJ BOT-360 corridor (3.6 m × 8 m, 1.6 m entrances),
    half of each stream leaving by each side of the far gap."""
    from crowdmotion import empirical as E
    from crowdmotion.cases import Setup

    groups = []
    for name, spawn, gx in (("east", Rect([-2.7, -1.9], [4.7, 5.5]), (17.4, 20.4)),
                            ("west", Rect([21.3, -1.9], [28.7, 5.5]), (5.6, 8.6))):
        groups.append(E._walkers(f"{name} south", 30, spawn, Rect([gx[0], -3.7], [gx[1], -2.5])))
        groups.append(E._walkers(f"{name} north", 30, spawn, Rect([gx[0], 6.1], [gx[1], 7.3])))
    return Setup(E.bot_corridor(1.6), groups, E._params("rvo", max_steps=1200, counterflow=counterflow))


def test_two_streams_in_a_corridor_form_lanes_and_pass():
    from crowdmotion import empirical as E
    from crowdmotion.cases import simulate

    runs = []  # lane order and speed with the counterflow term, and without it
    for seed in range(4):
        lanes = simulate("rvo", _bot_counterflow(20.0), seed)
        mixed = simulate("rvo", _bot_counterflow(0.0), seed)
        assert lanes.summary["arrival_rate"] == 1.0 and lanes.summary["agent_agent_overlaps"] == 0
        _, v, order, shuffled = E.bot_measures(lanes.traj, np.random.default_rng(0))
        _, v_mixed, order_mixed, _ = E.bot_measures(mixed.traj, np.random.default_rng(0))
        # lanes: the order well above the shuffled labels' (which is 0.5-0.7 here, with one or
        # two neighbours in the window: a ratio to it cannot say more)
        assert order >= shuffled + 0.15, "the streams walk in lanes"
        runs.append((order, v, order_mixed, v_mixed))
    # on average over the seeds (one run's order spreads by about ±0.07: 0.76-0.97 over seeds
    # 0-13): the order near its maximum of 1, and lanes are what lets them pass
    order, v, order_mixed, v_mixed = np.mean(runs, axis=0)
    assert order >= 0.85, runs
    assert order > order_mixed + 0.2 and v > v_mixed + 0.2, runs


@pytest.mark.parametrize("cells_per_step", [None, 2000])
def test_at_a_games_frame_rate_the_fields_are_re_solved_over_several_frames_and_taken_together(cells_per_step,
                                                                                                  monkeypatch):
    # at the default budget the searches fit in a quarter second; with a budget of 2000
    # cells a step, the six fields' searches (14,000 cells each at most) spread further
    import crowdmotion as cm
    from crowdmotion import rvo
    from crowdmotion.rvo import congestion
    from crowdmotion.rvo import simulator as rvo_simulator

    if cells_per_step is not None:
        monkeypatch.setattr(rvo_simulator, "REPLAN_CELLS_PER_STEP", cells_per_step)
    budget = rvo_simulator.REPLAN_CELLS_PER_STEP
    scene = cm.Scene(bounds=([0, 0], [40, 30]), obstacles=[cm.Circle([20, 15], 2.5)])
    for regions in ([cm.Rect([1, 1 + 3 * k], [3, 3 + 3 * k]) for k in range(6)], [cm.Rect([1, 1], [3, 29])]):
        sim = rvo.Simulator(scene, time_step=1 / 60)
        for k, region in enumerate(regions):
            sim.add_agents([[30 + k, 5], [30 + k, 25]], region.center, goal_region=region)
        sim.step()  # the period's first step: the crowd's costs taken, the first slices solved
        weights = sim._weights
        settled = []
        real = congestion.FieldSearch.advance

        def advance(self, pops, real=real):
            before = self.settled
            done = real(self, pops)
            settled.append((sim.steps, self.settled - before))
            return done

        congestion.FieldSearch.advance = advance
        try:
            fields = [sim._fields.dist]
            for _ in range(sim.replan_steps - 1):
                sim.step()
                fields.append(sim._fields.dist)
        finally:
            congestion.FieldSearch.advance = real
        nodes = len(sim._router.graph.cell_index)
        per_step = {}
        for step, n in settled:
            per_step[step] = per_step.get(step, 0) + n
        quarter = round(rvo_simulator.REPLAN_SPREAD_S * 60)  # the frames of a quarter second
        frames = max(quarter, -(-len(regions) * nodes // budget))
        assert frames <= sim.replan_steps
        assert len(per_step) > frames // 2, f"the searches ran in {len(per_step)} frames"
        assert max(per_step.values()) <= -(-len(regions) * nodes // frames), "no frame settles more than its share"
        assert max(per_step.values()) <= max(budget, -(-len(regions) * nodes // quarter))
        changed = [k for k in range(1, len(fields)) if fields[k] is not fields[k - 1]]
        assert len(changed) == 1, "the new fields are taken in one frame, together"
        taken = fields[changed[0]]
        for k in range(len(regions)):  # as the whole search from the period's crowd gives them where solved
            whole = sim._router.graph.distances_on(weights, [sim._fields.goal_cells[k]], taken.shape[1:])[0]
            solved = np.isfinite(taken[k])
            np.testing.assert_allclose(taken[k][solved], whole[solved])
