"""The shared numeric helpers give numpy's own numbers."""

import numpy as np

from crowdmotion.geometry import box_of, row_norms


def test_row_norms_are_numpys_norms_bit_for_bit():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(5000, 2)) * rng.lognormal(sigma=3.0, size=(5000, 1))
    v[:3] = [[0.0, 0.0], [-3.0, 4.0], [1e-200, 0.0]]
    assert np.array_equal(row_norms(v), np.linalg.norm(v, axis=1))
    assert row_norms(v)[1] == 5.0


def test_box_of_is_the_min_and_max_of_each_column():
    rng = np.random.default_rng(4)
    p = rng.uniform(-50, 20, size=(777, 2))
    lo, hi = box_of(p)
    assert np.array_equal(lo, p.min(axis=0)) and np.array_equal(hi, p.max(axis=0))
    lo, hi = box_of(np.array([[2.0, -1.0]]))
    assert lo.tolist() == [2.0, -1.0] and hi.tolist() == [2.0, -1.0]
