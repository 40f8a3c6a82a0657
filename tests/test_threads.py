"""@threaded kernels: a serial twin for small inputs, threads for large ones, and no more
threads than other processes leave cores free."""

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


@threaded
def _shifted(a, k, out):
    """out = a + k."""
    for i in prange(a.shape[0]):
        out[i] = a[i] + k


def test_small_inputs_compile_and_run_only_the_serial_twin(monkeypatch):
    monkeypatch.setattr(_threads, "PARALLEL_MIN_ITEMS", 100)
    a, out = np.arange(10.0), np.empty(10)
    _scaled(a, 3.0, out)
    np.testing.assert_array_equal(out, 3.0 * a)
    assert _scaled.serial.signatures and not _scaled.threaded.signatures


@pytest.mark.skipif(numba.get_num_threads() == 1, reason="one thread: always the serial twin")
def test_large_inputs_run_the_threaded_kernel_with_the_same_result(monkeypatch):
    monkeypatch.setattr(_threads, "PARALLEL_MIN_ITEMS", 100)
    monkeypatch.setattr(_threads, "_free_cores", None)  # every core free, however busy this machine is
    a, out = np.arange(500.0), np.empty(500)
    _scaled(a, 2.0, out)
    np.testing.assert_array_equal(out, 2.0 * a)
    assert _scaled.threaded.signatures


@threaded(min_items=20)
def _doubled(a, out):
    """out = 2a, a kernel with its own threshold."""
    for i in prange(a.shape[0]):
        out[i] = 2.0 * a[i]


@pytest.mark.skipif(numba.get_num_threads() == 1, reason="one thread: always the serial twin")
def test_a_kernel_with_its_own_threshold_threads_from_it_unless_the_environment_sets_one(monkeypatch):
    monkeypatch.setattr(_threads, "_free_cores", None)  # every core free, however busy this machine is
    a, out = np.arange(50.0), np.empty(50)  # under the default 1000 rows, over the kernel's 20
    _doubled(a, out)
    np.testing.assert_array_equal(out, 2.0 * a)
    assert _doubled.threaded.signatures and not _doubled.serial.signatures
    monkeypatch.setattr(_threads, "_MIN_FROM_ENV", "1000")  # CROWDMOTION_PARALLEL_MIN=1000: one threshold for all
    assert _doubled.min_items() == _threads.PARALLEL_MIN_ITEMS
    _doubled(a, out)  # the same 50 rows, now under the threshold
    assert _doubled.serial.signatures


@threaded(min_items=20, error_model="numpy")
def _ratio(a, b, out):
    """out = a / b, compiled with numpy's error model."""
    for i in prange(a.shape[0]):
        out[i] = a[i] / b[i]


@pytest.mark.parametrize("rows", [10, 50])  # the serial twin, then (with two threads) the threaded kernel
def test_compile_options_reach_both_twins_a_division_by_zero_gives_inf(monkeypatch, rows):
    monkeypatch.setattr(_threads, "_free_cores", None)
    a, b, out = np.ones(rows), np.zeros(rows), np.empty(rows)
    _ratio(a, b, out)  # raises ZeroDivisionError under numba's default (Python's) error model
    assert np.isinf(out).all()


def test_the_twins_keep_separate_cache_entries():
    # one cache slot for both would hand the serial caller the threaded machine code
    assert _scaled.serial.py_func.__qualname__ != _scaled.threaded.py_func.__qualname__
    assert _scaled.__doc__ == _scaled.threaded.py_func.__doc__


class _Machine:
    """A fake /proc/stat and clocks: CPUs whose busy time and this process's CPU time
    advance as a test says."""

    def __init__(self, cpus=2):
        self.busy = [0.0] * cpus  # seconds
        self.now = 0.0
        self.own = 0.0

    def run(self, seconds, own_cores, other_cores):
        """``seconds`` pass with this process on ``own_cores`` and others on ``other_cores``."""
        self.now += seconds
        self.own += own_cores * seconds
        load = own_cores + other_cores
        for c in range(len(self.busy)):
            self.busy[c] += min(max(load - c, 0.0), 1.0) * seconds

    def stat(self):
        hz = _threads._TICKS_PER_S
        lines = ["cpu  0 0 0 0 0 0 0 0 0 0"]
        for c, b in enumerate(self.busy):
            idle = int(round((self.now - b) * hz))
            lines.append(f"cpu{c} {int(round(b * hz))} 0 0 {idle} 0 0 0 0 0 0")
        return "\n".join(lines + ["intr 0", "ctxt 0"])


def _free(machine, cpus=(0, 1)):
    return _threads.FreeCores(reader=machine.stat, clock=lambda: machine.now, own=lambda: machine.own, cpus=cpus)


def test_a_core_kept_busy_by_another_process_is_not_used():
    m = _Machine()
    free = _free(m)
    m.run(1.0, own_cores=1.0, other_cores=1.0)
    assert free.threads(2) == 1
    m.run(1.0, own_cores=1.0, other_cores=0.0)  # the other process ended
    assert free.threads(2) == 2


def test_this_process_own_work_does_not_count_as_busy():
    m = _Machine()
    free = _free(m)
    m.run(1.0, own_cores=2.0, other_cores=0.0)
    assert free.threads(2) == 2
    assert free.threads(1) == 1  # never more than numba's thread count


def test_a_core_busy_now_and_then_still_counts_as_free():
    m = _Machine(cpus=4)
    free = _free(m, cpus=range(4))
    m.run(1.0, own_cores=1.0, other_cores=0.2)
    assert free.threads(4) == 4
    m.run(1.0, own_cores=1.0, other_cores=2.5)  # two and a half cores taken: one and a half free
    assert free.threads(4) == 1
    m.run(1.0, own_cores=1.0, other_cores=4.0)  # all taken by others: still one thread
    assert free.threads(4) == 1


def test_the_measurement_waits_for_a_window_of_sample_s():
    m = _Machine()
    free = _free(m)
    m.run(_threads.SAMPLE_S / 2, own_cores=1.0, other_cores=1.0)
    assert free.threads(2) == 2  # too short a window: as before
    m.run(_threads.SAMPLE_S, own_cores=1.0, other_cores=1.0)
    assert free.threads(2) == 1


def test_only_the_cpus_this_process_may_run_on_count():
    m = _Machine(cpus=4)
    free = _free(m, cpus=(0, 1))
    m.run(1.0, own_cores=0.0, other_cores=2.0)  # others on cpus 0 and 1
    assert free.threads(2) == 1
    m = _Machine(cpus=4)
    free = _free(m, cpus=(2, 3))
    m.run(1.0, own_cores=0.0, other_cores=2.0)
    assert free.threads(2) == 2


def test_without_proc_stat_every_thread_is_used():
    def unreadable():
        raise OSError("no /proc here")

    free = _threads.FreeCores(reader=unreadable, cpus=(0, 1, 2, 3))
    assert free.threads(4) == 4


@pytest.mark.skipif(numba.get_num_threads() == 1, reason="one thread: always the serial twin")
def test_busy_cores_run_the_serial_twin_with_the_same_result(monkeypatch):
    monkeypatch.setattr(_threads, "PARALLEL_MIN_ITEMS", 100)
    m = _Machine(cpus=numba.get_num_threads())
    monkeypatch.setattr(_threads, "_free_cores", _free(m, cpus=range(numba.get_num_threads())))
    m.run(1.0, own_cores=0.0, other_cores=numba.get_num_threads())
    a, out = np.arange(600.0), np.empty(600)
    _shifted(a, 4.0, out)
    np.testing.assert_array_equal(out, a + 4.0)
    assert _shifted.serial.signatures and not _shifted.threaded.signatures
    assert numba.get_num_threads() == m.busy.__len__()  # numba's own setting untouched
