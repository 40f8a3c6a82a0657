"""@threaded kernels: a serial twin for small inputs, threads for large ones (issue 16)."""

import numba
import numpy as np
import pytest
from numba import prange

from crowdmotion import _threads
from crowdmotion._threads import threaded


@threaded
def _scaled(a, k, out):
    """out = k a."""
    for i in prange(a.shape[0]):
        out[i] = k * a[i]


def test_small_inputs_compile_and_run_only_the_serial_twin(monkeypatch):
    monkeypatch.setattr(_threads, "PARALLEL_MIN_ITEMS", 100)
    a, out = np.arange(10.0), np.empty(10)
    _scaled(a, 3.0, out)
    np.testing.assert_array_equal(out, 3.0 * a)
    assert _scaled.serial.signatures and not _scaled.threaded.signatures


@pytest.mark.skipif(numba.get_num_threads() == 1, reason="one thread: always the serial twin")
def test_large_inputs_run_the_threaded_kernel_with_the_same_result(monkeypatch):
    monkeypatch.setattr(_threads, "PARALLEL_MIN_ITEMS", 100)
    a, out = np.arange(500.0), np.empty(500)
    _scaled(a, 2.0, out)
    np.testing.assert_array_equal(out, 2.0 * a)
    assert _scaled.threaded.signatures


def test_the_twins_keep_separate_cache_entries():
    # one cache slot for both would hand the serial caller the threaded machine code
    assert _scaled.serial.py_func.__qualname__ != _scaled.threaded.py_func.__qualname__
    assert _scaled.__doc__ == _scaled.threaded.py_func.__doc__
