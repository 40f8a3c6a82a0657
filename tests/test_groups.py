"""Regions: the nearest point of a goal area, against closed forms and brute force."""

import numpy as np

from crowdmotion.groups import Disc, Points, Rect


def test_the_nearest_point_of_a_rect_is_the_closest_of_a_fine_grid_of_its_points():
    rect = Rect([1, 2], [4, 3])
    rng = np.random.default_rng(0)
    q = rng.uniform(-3, 8, (50, 2))
    xs, ys = np.meshgrid(np.linspace(1, 4, 301), np.linspace(2, 3, 101))
    grid = np.c_[xs.ravel(), ys.ravel()]
    brute = grid[np.argmin(np.linalg.norm(q[:, None] - grid[None], axis=2), axis=1)]
    assert np.allclose(rect.nearest(q), brute, atol=0.006)
    inside = rect.contains(q)
    assert np.array_equal(rect.nearest(q)[inside], q[inside])


def test_the_nearest_point_of_a_disc_lies_on_the_ray_from_its_centre_at_its_radius():
    disc = Disc([2, -1], 1.5)
    q = np.array([[5.0, 3.0], [2.5, -1.0], [2.0, -1.0]])
    out = disc.nearest(q)
    assert np.allclose(out[0], [2 + 1.5 * 0.6, -1 + 1.5 * 0.8])  # the 3-4-5 ray
    assert np.allclose(out[1:], q[1:])  # inside (the centre too): itself


def test_the_nearest_of_listed_points_is_the_closest_one():
    pts = Points([[0, 0], [10, 0], [5, 5]])
    assert pts.nearest([[9, 1], [4, 3], [-1, -1]]).tolist() == [[10, 0], [5, 5], [0, 0]]
