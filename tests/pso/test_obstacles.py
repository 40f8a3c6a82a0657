"""The swarm's obstacles as arrays, and the grid that lists the obstacles near each cell."""

import numpy as np
import pytest

from crowdmotion.pso.obstacles import ObstacleArrays


def _cell(p, origin, h, dims):
    c = np.clip(np.floor((p - origin) / h), 0, dims - 1).astype(int)
    return int(c[0] + dims[0] * (c[1] + (dims[1] * c[2] if len(c) == 3 else 0)))


@pytest.mark.parametrize("dim", [2, 3])
def test_a_particle_near_an_obstacle_finds_it_in_its_own_cell(dim):
    rng = np.random.default_rng(dim)
    sc = rng.uniform(0, 20, (6, dim))
    sr = rng.uniform(0.3, 2.0, 6)
    bl = rng.uniform(0, 20, (5, dim))
    bu = bl + rng.uniform(0.2, 4.0, (5, dim))
    obstacles = ObstacleArrays(sc, sr, bl, bu)
    origin, h, expand = np.zeros(dim), 2.5, 1.7
    dims = np.full(dim, 8, np.int64)
    start, items = obstacles.grid(expand, origin, h, dims)
    assert start[0] == 0 and start[-1] == len(items) and np.all(np.diff(start) >= 0)
    for c in range(len(start) - 1):
        listed = items[start[c]:start[c + 1]].tolist()
        spheres, boxes = [j for j in listed if j >= 0], [-j - 1 for j in listed if j < 0]
        assert listed == sorted(spheres) + [-b - 1 for b in sorted(boxes)]  # spheres, then boxes, no repeats
    for p in rng.uniform(-3, 23, (3000, dim)):  # points beyond the grid belong to its outermost cells
        c = _cell(p, origin, h, dims)
        listed = set(items[start[c]:start[c + 1]].tolist())
        near_spheres = np.flatnonzero(np.linalg.norm(sc - p, axis=1) - sr <= expand)
        near_boxes = np.flatnonzero(np.linalg.norm(np.clip(p, bl, bu) - p, axis=1) <= expand)
        assert set(near_spheres.tolist()) | {-b - 1 for b in near_boxes.tolist()} <= listed


def test_no_obstacles_give_empty_cells():
    empty = ObstacleArrays(np.empty((0, 2)), np.empty(0), np.empty((0, 2)), np.empty((0, 2)))
    start, items = empty.grid(1.0, np.zeros(2), 1.0, np.array([3, 4]))
    assert start.tolist() == [0] * 13 and len(items) == 0
