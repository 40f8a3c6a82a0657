"""State values: the fast solver against an independent scipy graph; the paper's solvers' θ rule."""

import itertools
import math

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra as sp_dijkstra

from crowdmotion import mdp
from crowdmotion.mdp._kernels import PARALLEL_MIN, PARALLEL_MIN_2D
from crowdmotion.mdp.benchmark import PAPER_GRIDS, csgraph_values, paper_grid
from crowdmotion.mdp.solvers import fast_values


def scipy_reference(grid, goals, corner_cutting):
    """Shortest paths on a graph built here by plain enumeration of cells and moves."""
    shape = grid.shape
    rows, cols, w = [], [], []
    moves = [m for m in itertools.product((-1, 0, 1), repeat=grid.ndim) if any(m)]
    for cell in itertools.product(*(range(s) for s in shape)):
        if grid[cell]:
            continue
        for m in moves:
            nb = tuple(c + d for c, d in zip(cell, m))
            if any(x < 0 or x >= s for x, s in zip(nb, shape)) or grid[nb]:
                continue
            if not corner_cutting:
                # every cell the straight move sweeps past: all partial sums of its axes
                nz = [k for k in range(grid.ndim) if m[k]]
                blocked = False
                for r in range(1, len(nz)):
                    for axes in itertools.combinations(nz, r):
                        mid = tuple(c + (m[k] if k in axes else 0) for k, c in enumerate(cell))
                        blocked |= bool(grid[mid])
                if blocked:
                    continue
            rows.append(np.ravel_multi_index(cell, shape))
            cols.append(np.ravel_multi_index(nb, shape))
            w.append(math.sqrt(sum(abs(x) for x in m)))
    g = sp.csr_matrix((w, (rows, cols)), shape=(grid.size, grid.size))
    d = sp_dijkstra(g, indices=[np.ravel_multi_index(t, shape) for t in goals], min_only=True)
    return -d.reshape(shape)


def assert_same_values(v, ref):
    """Same reachable cells, values within 1e-9; returns the reachable mask."""
    np.testing.assert_array_equal(np.isfinite(v), np.isfinite(ref))
    fin = np.isfinite(ref)
    assert np.max(np.abs(v[fin] - ref[fin])) < 1e-9
    return fin


def random_grid(shape, density, seed):
    rng = np.random.default_rng(seed)
    g = (rng.random(shape) < density).astype(np.uint8)
    free = np.argwhere(g == 0)
    goals = [tuple(int(x) for x in free[i]) for i in rng.choice(len(free), size=2, replace=False)]
    return g, goals


@pytest.mark.parametrize("corner_cutting", [True, False])
@pytest.mark.parametrize("shape,seed", [((40, 31), 0), ((25, 25), 1), ((9, 11, 8), 2), ((12, 12, 12), 3)])
def test_fast_equals_scipy_shortest_paths(shape, seed, corner_cutting):
    grid, goals = random_grid(shape, 0.3, seed)
    v = fast_values(grid.astype(np.uint8), goals, corner_cutting)
    ref = scipy_reference(grid, goals, corner_cutting)
    assert_same_values(v, ref)
    assert np.all(v[grid == 1] == -np.inf)
    assert all(v[g] == 0 for g in goals)


@pytest.mark.parametrize("threads", [2, 7])
@pytest.mark.parametrize("corner_cutting", [True, False])
def test_fast_equals_scipy_on_a_3d_grid_big_enough_for_the_threads(corner_cutting, threads):
    """Buckets over PARALLEL_MIN cells are split by plane into a part per thread, at most
    MAX_PARTS (asking for 7 runs 4 parts on this machine's threads all the same: the
    split and the three seams are exercised)."""
    grid, _ = random_grid((66, 60, 64), 0.08, 4)
    grid[20, 5:45, 3:50] = 1  # a wall the fronts must bend round
    goals = [(33, 30, 32), (60, 10, 50)]
    grid[tuple(np.array(goals).T)] = 0
    v = fast_values(grid.astype(np.uint8), goals, corner_cutting, threads=threads)
    ref = csgraph_values(grid, goals, corner_cutting)
    fin = assert_same_values(v, ref)
    assert np.bincount((-ref[fin]).astype(int)).max() >= PARALLEL_MIN  # the split really ran


@pytest.mark.parametrize("threads", [2, 7])
@pytest.mark.parametrize("corner_cutting", [True, False])
@pytest.mark.parametrize("goals", ["two cells", "a whole row"])
def test_fast_equals_scipy_on_a_2d_grid_big_enough_for_the_threads(corner_cutting, goals, threads):
    """2D buckets over PARALLEL_MIN_2D cells are split by row in two (whatever the threads); a
    row goal puts a whole front into the seam rows."""
    grid, _ = random_grid((700, 600), 0.1, 5)
    grid[300, 50:550] = 1
    cells = [(350, 300), (10, 20)] if goals == "two cells" else [(699, c) for c in range(600)]
    grid[tuple(np.array(cells).T)] = 0
    v = fast_values(grid.astype(np.uint8), cells, corner_cutting, threads=threads)
    ref = csgraph_values(grid, cells, corner_cutting)
    fin = assert_same_values(v, ref)
    assert np.bincount((-ref[fin]).astype(int)).max() >= PARALLEL_MIN_2D


def test_corner_rule_changes_values_around_a_diagonal_gap():
    grid = np.zeros((3, 3), np.uint8)
    grid[1, 0] = grid[0, 1] = 1  # (0,0) reaches (1,1) only by cutting the corner
    cut = mdp.solve(grid, (1, 1), corner_cutting=True)
    nocut = mdp.solve(grid, (1, 1), corner_cutting=False)
    assert cut[0, 0] == pytest.approx(-math.sqrt(2))
    assert nocut[0, 0] == -np.inf


@pytest.mark.parametrize("method", ["dijkstra", "dijkstra_unsorted"])
@pytest.mark.parametrize("shape,goal,lo,hi", PAPER_GRIDS[:6])
def test_reference_dijkstra_is_exact(shape, goal, lo, hi, method):
    grid = paper_grid(shape, lo, hi)
    exact = mdp.solve(grid, goal, "fast")
    ref = mdp.solve(grid, goal, method)
    fin = np.isfinite(exact)
    assert np.max(np.abs(ref[fin] - exact[fin])) < 1e-9
    assert np.array_equal(np.isfinite(ref), fin)  # the same cells unreachable (the unsorted scan stops early)


def test_unsorted_dijkstra_stops_at_a_walled_off_region():
    grid = np.zeros((6, 6), np.uint8)
    grid[:, 3] = 1  # columns 4-5 cannot be reached from the goal
    v = mdp.solve(grid, (0, 0), "dijkstra_unsorted", corner_cutting=False)
    assert np.all(v[:, 4:] == -np.inf) and np.all(np.isfinite(v[:, :3]))


def _error(grid, goal, method):
    """Largest |v - exact| over reachable cells, checking the side each solver errs on."""
    exact = mdp.solve(grid, goal, "fast")
    v = mdp.solve(grid, goal, method, theta=1.0)
    fin = np.isfinite(exact)
    assert np.all(np.isfinite(v[fin])) and np.all(v[~fin] == -np.inf)
    if method == "hvi":  # starts optimistic (-Euclidean >= -path) and stays above
        assert np.all(v[fin] >= exact[fin] - 1e-9)
    else:  # VI and IVI values are lengths of real paths: never better than the shortest
        assert np.all(v[fin] <= exact[fin] + 1e-9)
    return float(np.max(np.abs(v[fin] - exact[fin])))


def test_how_far_the_papers_solvers_end_from_exact():
    """Measured on the paper's grids with θ = 1 (documented in docs/mdp.md)."""
    g2 = paper_grid(*[PAPER_GRIDS[4][i] for i in (0, 2, 3)])
    g3 = paper_grid(*[PAPER_GRIDS[6][i] for i in (0, 2, 3)])
    goal2, goal3 = PAPER_GRIDS[4][1], PAPER_GRIDS[6][1]
    assert _error(g2, goal2, "vi") < 1e-9  # from -inf, VI's sweeps are exact once Δ < 1
    assert _error(g2, goal2, "ivi") < 1e-9  # 2D: Algorithm 2 + 1 end exact
    assert 0.2 < _error(g3, goal3, "ivi") < 1.0  # 3D: IVI is NOT exact (0.578 on 20^3)
    assert 1.0 < _error(g2, goal2, "hvi") < 3.0  # HVI stops > θ from exact (1.976 on 50x50)


def test_value_iteration_stops_by_theta_rule():
    grid = paper_grid(*[PAPER_GRIDS[2][i] for i in (0, 2, 3)])
    goal = PAPER_GRIDS[2][1]
    _, sweeps_tight = mdp.value_iteration(grid, [goal], theta=1e-9)
    _, sweeps_paper = mdp.value_iteration(grid, [goal], theta=1.0)
    assert sweeps_paper <= sweeps_tight


def test_greedy_estimate_sets_each_value_once_and_is_an_overestimate():
    grid = paper_grid((30, 30), (15, 10), (15, 19))
    est = mdp.greedy_estimate(grid, [(29, 15)])
    exact = mdp.solve(grid, (29, 15))
    fin = np.isfinite(exact)
    assert np.all(est[fin] <= exact[fin] + 1e-9)  # first discovery never beats the best path


def test_unreachable_cells_are_minus_inf_for_every_method():
    grid = np.zeros((7, 7), np.uint8)
    grid[3, :] = 1  # a full wall: the lower half cannot reach the goal
    for m in mdp.METHODS:
        v = mdp.solve(grid, (6, 3), m)
        assert np.all(v[:3] == -np.inf), m
        assert np.all(np.isfinite(v[4:])), m


@pytest.mark.parametrize("goal,msg", [((0, 0), "obstacle"), ((9, 9), "outside"), ([(1.5, 2)], "integer")])
def test_bad_goals_are_named(goal, msg):
    grid = np.zeros((5, 5), np.uint8)
    grid[0, 0] = 1
    with pytest.raises(ValueError, match=msg):
        mdp.solve(grid, goal)


def test_bad_grids_and_arguments():
    with pytest.raises(ValueError, match="0 \\(free\\) and 1"):
        mdp.solve(np.full((3, 3), 2), (0, 0))
    with pytest.raises(ValueError, match="2 or 3 axes"):
        mdp.solve(np.zeros(5), (0,))
    with pytest.raises(ValueError, match="method"):
        mdp.solve(np.zeros((3, 3)), (0, 0), method="astar")
    with pytest.raises(ValueError, match="theta"):
        mdp.solve(np.zeros((3, 3)), (0, 0), method="vi", theta=float("nan"))
    with pytest.raises(MemoryError, match="a grid of 2e\\+05 x 2e\\+05 cells needs about .* solve a coarser grid"):
        mdp.solve(np.lib.stride_tricks.as_strided(np.zeros(1, np.uint8), (200_000, 200_000), (0, 0)), (0, 0))


def test_a_scene_rastered_too_fine_is_refused_before_it_is_allocated():
    from crowdmotion.mdp.grid import rasterise
    from crowdmotion.scene import Scene

    with pytest.raises(MemoryError, match="a grid of 0.01 m cells over this scene has 1e\\+06 x 1e\\+06 cells .* "
                                          "use a larger mdp.cell_size, or smaller scene.bounds"):
        rasterise(Scene(bounds=([0, 0], [10_000, 10_000])), 0.01)
