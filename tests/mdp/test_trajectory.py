"""Algorithm 3: grid invariants, determinism, and crossing-freedom in continuous time."""

import numpy as np
import pytest

from crowdmotion import Trajectories, mdp
from crowdmotion.mdp.moves import swept_offsets
from crowdmotion.metrics import collision_audit


def crowd(shape=(30, 30), n=120, seed=0, corner_cutting=True, **kw):
    grid = np.zeros(shape, np.uint8)
    grid[15, 5:25] = 1
    grid[5:9, 20] = 1
    v = mdp.solve(grid, (29, 15), corner_cutting=corner_cutting)
    rng = np.random.default_rng(seed)
    free = np.argwhere(grid == 0)
    starts = free[rng.choice(len(free), n, replace=False)]
    cells = mdp.generate_trajectories(grid, v, starts, 80, np.random.default_rng(seed + 1),
                                      corner_cutting=corner_cutting, **kw)
    return grid, v, cells


def as_world(cells, radius=mdp.RAW_GRID_RADIUS):
    return Trajectories(cells.astype(float) + 0.5, dt=1.0, radius=radius)


@pytest.mark.parametrize("corner_cutting", [True, False])
def test_grid_invariants_hold_at_every_step(corner_cutting):
    grid, v, cells = crowd(corner_cutting=corner_cutting)
    T, N, D = cells.shape
    for t in range(T):
        assert len({tuple(c) for c in cells[t]}) == N, f"two agents share a cell at step {t}"
        assert not grid[tuple(cells[t].T)].any(), "an agent entered an obstacle"
    step = cells[1:] - cells[:-1]
    assert np.abs(step).max() <= 1, "every move is to a neighbour or a stay"
    for t in range(T - 1):  # no two agents swap cells
        before = {tuple(c): i for i, c in enumerate(cells[t])}
        for i in range(N):
            j = before.get(tuple(cells[t + 1, i]))
            if j is not None and j != i:
                assert tuple(cells[t + 1, j]) != tuple(cells[t, i])
    if not corner_cutting:
        diag = np.abs(step).sum(axis=-1) > 1
        for t, i in zip(*np.nonzero(diag)):
            a, m = cells[t, i], step[t, i]
            nz = [k for k in range(D) if m[k]]
            for k in nz:  # the axis-aligned cells beside a diagonal are free
                side = a.copy()
                side[k] += m[k]
                assert grid[tuple(side)] == 0


def test_agents_reach_the_goal_area():
    grid, v, cells = crowd(n=40)
    start = -v[tuple(cells[0].T)]
    end = -v[tuple(cells[-1].T)]
    assert end.mean() < 0.3 * start.mean()
    assert (end == 0).sum() == 1  # one goal cell, absorbing: exactly one agent stands on it


def test_despawn_lets_every_agent_take_the_goal_cell():
    grid = np.zeros((12, 12), np.uint8)
    v = mdp.solve(grid, (11, 6))
    starts = np.array([(0, y) for y in range(0, 12, 2)])
    cells, active = mdp.generate_trajectories(grid, v, starts, 120, np.random.default_rng(0), despawn=True,
                                              return_active=True)
    assert not active[-1].any()
    assert np.all((cells[-1] == (11, 6)).all(axis=1))


def test_same_seed_same_paths_other_seed_other_paths():
    _, _, a = crowd(seed=3)
    _, _, b = crowd(seed=3)
    _, _, c = crowd(seed=4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a[1:], c[1:])


def test_forbid_crossing_gives_zero_continuous_overlaps():
    for seed in range(3):
        _, _, cells = crowd(n=250, seed=seed)
        report = collision_audit(as_world(cells))
        assert report.agent_agent == 0, report.events[:3]


def test_audit_catches_crossings_when_the_option_is_off():
    found = 0
    for seed in range(3):
        _, _, cells = crowd(n=250, seed=seed, forbid_crossing=False)
        found += collision_audit(as_world(cells)).agent_agent
    assert found > 0


def test_forbid_crossing_rejects_the_diagonal_x_swap():
    # two agents whose only improving moves cross in an X: with the option on they must not
    grid = np.ones((2, 4), np.uint8)
    grid[:, :2] = 0
    # (0,1) and (1,1) are equally good for both agents, so the X (0,0)->(1,1), (1,0)->(0,1)
    # is a candidate pair of moves unless the crossing rule removes it
    values = np.array([[-3.0, -1.5, -np.inf, -np.inf], [-3.0, -1.5, -np.inf, -np.inf]])
    starts = np.array([(0, 0), (1, 0)])
    crossed = 0
    for seed in range(20):
        on = mdp.generate_trajectories(grid, values, starts, 1, np.random.default_rng(seed), tau=0.01)
        assert collision_audit(as_world(on)).agent_agent == 0
        off = mdp.generate_trajectories(grid, values, starts, 1, np.random.default_rng(seed), tau=0.01,
                                        forbid_crossing=False)
        crossed += collision_audit(as_world(off)).agent_agent
    assert crossed > 0


def test_unreachable_agents_stay_put():
    grid = np.zeros((7, 7), np.uint8)
    grid[3, :] = 1
    v = mdp.solve(grid, (6, 3))
    cells = mdp.generate_trajectories(grid, v, np.array([(0, 0), (5, 5)]), 20, np.random.default_rng(0))
    assert np.all(cells[:, 0] == (0, 0))


@pytest.mark.parametrize("starts,msg", [
    ([(3, 0)], "obstacle"), ([(0, 0), (0, 0)], "share"), ([(9, 0)], "outside"), ([(0.5, 1)], "integer"),
])
def test_bad_starts_are_named(starts, msg):
    grid = np.zeros((7, 7), np.uint8)
    grid[3, :] = 1
    v = mdp.solve(grid, (6, 3))
    with pytest.raises(ValueError, match=msg):
        mdp.generate_trajectories(grid, v, np.array(starts), 5, np.random.default_rng(0))


def test_3d_trajectories_keep_invariants():
    grid = np.zeros((10, 10, 10), np.uint8)
    grid[5, 2:8, 2:8] = 1
    v = mdp.solve(grid, (9, 5, 5), corner_cutting=False)
    rng = np.random.default_rng(0)
    free = np.argwhere(grid[:4] == 0)
    starts = free[rng.choice(len(free), 60, replace=False)]
    cells = mdp.generate_trajectories(grid, v, starts, 40, rng, corner_cutting=False)
    for t in range(len(cells)):
        assert len({tuple(c) for c in cells[t]}) == 60
    assert collision_audit(as_world(cells)).agent_agent == 0
    assert len(swept_offsets(3)[0]) == 6  # a 3D corner move sweeps past six cells


def _threaded_scene(case, n=700):
    """A crowd on the kernel's edge cases: dense (one big cluster) or sparse (many)."""
    dim = 3 if case == "3d" else 2
    shape = (16, 16, 16) if dim == 3 else (60, 60)
    grid = np.zeros(shape, np.uint8)
    grid[(slice(8, 9), slice(2, 12)) if dim == 3 else (slice(30, 31), slice(10, 50))] = 1
    goal = (15, 8, 8) if dim == 3 else (59, 30)
    corner_cutting = case != "no_corner_cutting"
    v = mdp.solve(grid, goal, corner_cutting=corner_cutting)
    rng = np.random.default_rng(5)
    free = np.argwhere(grid == 0)
    starts = free[rng.choice(len(free), n, replace=False)]
    kw = dict(corner_cutting=corner_cutting, despawn=case == "despawn", forbid_crossing=case != "crossing_off",
              return_active=True)
    return grid, v, starts, kw


@pytest.mark.parametrize("parts,n", [(2, 700), (3, 150)])
@pytest.mark.parametrize("case", ["2d", "3d", "despawn", "crossing_off", "no_corner_cutting"])
def test_threads_give_the_one_thread_paths_bit_for_bit(monkeypatch, case, parts, n):
    from crowdmotion.mdp import trajectory

    grid, v, starts, kw = _threaded_scene(case, n)
    one = mdp.generate_trajectories(grid, v, starts, 60, np.random.default_rng(2), **kw)
    monkeypatch.setattr(trajectory, "step_threads", lambda n: parts)
    shared = mdp.generate_trajectories(grid, v, starts, 60, np.random.default_rng(2), **kw)
    np.testing.assert_array_equal(shared[0], one[0])
    np.testing.assert_array_equal(shared[1], one[1])
    if case == "despawn":
        assert not one[1][-1].all(), "some agents despawned on the way"


def test_clusters_are_the_agents_within_two_cells_of_each_other():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    from crowdmotion.mdp import _kernels as K
    from crowdmotion.mdp.trajectory import RAW_GRID_RADIUS, Walker

    grid, v, starts, _ = _threaded_scene("2d", 150)
    goal = np.zeros(grid.shape, bool)
    goal[59, 30] = True
    walker = Walker(grid, starts, [goal], np.zeros(len(starts), np.int64), True, RAW_GRID_RADIUS)
    walker.set_values(v[None])
    walker.advance(25, np.random.default_rng(0), 1.0, True, False)  # clusters of many sizes by now
    n = len(starts)
    state = np.where(walker.blocked > 0, K.BLOCKED, 0).astype(np.uint8)
    state[walker.occ >= 0] |= K.TAKEN | K.STARTED
    order = np.argsort(-walker.values[0, walker.cur], kind="stable")
    near_ahead = walker.near_offsets[walker.near_offsets > 0]
    parts = 3
    root, first, owner = (np.empty(n, np.int64) for _ in range(3))
    K._clusters(order, walker.cur, walker.active, walker.occ, state, near_ahead, walker.near_offsets, parts, root,
                first, owner)

    np.testing.assert_array_equal(first[order], np.arange(n))
    np.testing.assert_array_equal(owner, first[root] * parts // n)  # the share its lowest-id agent's turn is in
    assert set(owner.tolist()) == {0, 1, 2}
    pairs = np.array(sorted(cKDTree(walker.cells).query_pairs(2.0 + 1e-9, p=np.inf)))
    linked = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    n_clusters, label = connected_components(linked, directed=False)
    assert np.bincount(label).max() > 1 and n_clusters > 10, "clusters of one and of several agents"
    for c in range(n_clusters):
        members = np.flatnonzero(label == c)
        assert np.all(root[members] == members.min()), "a cluster is named by its lowest agent id"
