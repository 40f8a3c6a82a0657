"""Algorithm 3's helper kernels against plain numpy: the priority order."""

import numpy as np
import pytest

from crowdmotion.mdp._kernels import _priority_order


@pytest.mark.parametrize("case", ["random", "ties", "inf", "one", "equal", "spread"])
def test_priority_order_is_a_stable_argsort(case):
    rng = np.random.default_rng(7)
    n = 5000
    keys = {"random": lambda: rng.normal(size=n),
            "ties": lambda: rng.integers(0, 20, n).astype(float),
            "inf": lambda: np.where(rng.random(n) < 0.1, np.inf, rng.normal(size=n)),
            "one": lambda: np.array([3.0]),
            "equal": lambda: np.full(n, 2.5),
            "spread": lambda: np.concatenate([rng.normal(size=n - 3), [1e12, -1e12, 0.0]])}[case]()
    n = len(keys)
    order = np.empty(n, dtype=np.int64)
    _priority_order(keys, order, np.empty(n, dtype=np.int64), np.empty(n + 2, dtype=np.int64))
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))


@pytest.mark.parametrize("shape", [(40, 31), (12, 15, 18)])
def test_near_cells_match_scipy_maximum_filter(shape):
    from scipy.ndimage import maximum_filter

    from crowdmotion.mdp._kernels import NEAR, mark_near
    from crowdmotion.mdp.solvers import padded

    grid = (np.random.default_rng(3).random(shape) < 0.05).astype(np.uint8)
    kind, strides = padded(grid)
    mark_near(kind, strides, np.empty(2 * kind.size, dtype=np.uint8))
    full = padded(grid)[0].reshape(tuple(s + 4 for s in shape))
    expected = (maximum_filter(full, size=3, mode="constant", cval=1) > 0) & (full == 0)
    np.testing.assert_array_equal((kind & NEAR).reshape(full.shape) > 0, expected)
