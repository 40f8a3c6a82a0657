"""The prefetch hint compiles into numba kernels and changes no result."""

import numpy as np
from numba import njit

from crowdmotion._prefetch import _llvm_prefetch, _noop, prefetch


def _gather_sum(hint):
    """A gather loop that calls ``hint(values, index)`` a few reads ahead."""

    @njit
    def gather(values, index):
        total = 0.0
        for k in range(index.shape[0]):
            if k + 4 < index.shape[0]:
                hint(values, index[k + 4])
            total += values[index[k]]
        return total

    return gather


def test_prefetch_is_the_llvm_intrinsic_here_and_changes_nothing():
    assert prefetch is _llvm_prefetch  # this numba/LLVM compiles it; else the no-op stands in
    values = np.random.default_rng(0).random(10_000)
    index = np.random.default_rng(1).integers(0, values.size, 5_000)
    expected = float(np.sum(values[index]))
    assert np.isclose(_gather_sum(prefetch)(values, index), expected, rtol=1e-12)
    assert np.isclose(_gather_sum(_noop)(values, index), expected, rtol=1e-12)
