"""Kernels that use threads only where they pay: ``@threaded`` compiles a numba kernel
twice on demand, with ``parallel=True`` for large inputs and without for small ones, and
runs the threaded one on no more threads than there are cores free.

A parallel region costs tens of microseconds a step, and compiling one costs seconds on
a fresh install (numba's parfor passes): for a kernel that spends a fraction of a
microsecond a row, on a scene of a few hundred agents, both are waste. ``@threaded``
gives a callable that runs the serial twin when the first argument has fewer than
``PARALLEL_MIN_ITEMS`` rows (or only one thread is to be had) and the threaded kernel
otherwise; only the one a run uses is compiled. A kernel whose rows cost microseconds
each names its own threshold (``@threaded(min_items=n)``: the RVO choice and lane
choice, from 250 agents). ``CROWDMOTION_PARALLEL_MIN`` sets one threshold for every
kernel (0: always threaded).

Busy cores. A parallel region ends when its slowest thread does: a thread that shares
its core with another process's work waits for the scheduler, and every region of the
step waits for it. On a 2-core machine with one core busy, the 2000-person stand
evacuation took three times as long on two threads as on one. So the threaded kernel
runs on at most the cores of this process's CPU set (``os.sched_getaffinity``) that
other processes leave free, measured from ``/proc/stat`` less this process's own CPU
time over the last ``SAMPLE_S`` seconds or more (:class:`FreeCores`), and never on more
than numba's thread count (``NUMBA_NUM_THREADS``, ``numba.set_num_threads``): one thread
means the serial twin. A core counts as free while others keep it busy less than
``BUSY_SHARE`` of the time. Where ``/proc/stat`` cannot be read (not Linux) every thread is
used, as before; ``CROWDMOTION_ADAPT_THREADS=0`` turns the measurement off.

The twins give the same numbers: the kernels give each agent its own output row, so the
thread count changes only the wall time.

The twin is a copy of the Python function under another name, so the two keep separate
entries in numba's on-disk cache.
"""

from __future__ import annotations

import os
import threading
import time
import types

import numba
from numba import njit

_MIN_FROM_ENV = os.environ.get("CROWDMOTION_PARALLEL_MIN")
PARALLEL_MIN_ITEMS = int(_MIN_FROM_ENV or "1000")
ADAPT = os.environ.get("CROWDMOTION_ADAPT_THREADS", "1") != "0"
SAMPLE_S = 0.5   # the busy cores are measured over at least this many seconds
BUSY_SHARE = 0.3  # a core that other processes keep busy this share of the time or more is not free


class FreeCores:
    """How many of this process's cores other processes leave free, measured over windows
    of at least ``SAMPLE_S`` seconds: the CPU time ``/proc/stat`` counts on the process's
    CPU set less the process's own (``time.process_time``), per second of wall time.

    ``reader`` returns the text of ``/proc/stat``; ``clock`` and ``own`` the wall and
    process times in seconds (replaceable for tests)."""

    def __init__(self, reader=None, clock=time.monotonic, own=time.process_time, cpus=None):
        self._read = reader or _read_proc_stat
        self._clock = clock
        self._own = own
        try:
            self.cpus = set(os.sched_getaffinity(0)) if cpus is None else set(cpus)
        except (AttributeError, OSError):
            self.cpus = set(range(os.cpu_count() or 1)) if cpus is None else set(cpus)
        self._lock = threading.Lock()
        self._pid = os.getpid()
        self._last = self._sample()
        self.free = float(len(self.cpus))  # until a window has passed: all free

    def _sample(self):
        """(wall s, own CPU s, busy CPU s on the CPU set) or None if /proc/stat is unreadable."""
        try:
            text = self._read()
        except OSError:
            return None
        busy = 0
        seen = False
        for line in text.splitlines():
            if not line.startswith("cpu") or line.startswith("cpu "):
                continue
            name, *fields = line.split()
            try:
                cpu = int(name[3:])
            except ValueError:
                continue
            if cpu not in self.cpus or len(fields) < 4:
                continue
            ticks = [int(f) for f in fields[:8]]
            # user nice system idle iowait irq softirq steal: all but idle and iowait are busy
            busy += sum(ticks) - ticks[3] - (ticks[4] if len(ticks) > 4 else 0)
            seen = True
        if not seen:
            return None
        return self._clock(), self._own(), busy / _TICKS_PER_S

    def cores(self) -> float:
        """Cores of the CPU set free of other processes' work (a float, refreshed at most
        every ``SAMPLE_S`` seconds); the whole set if it cannot be measured."""
        if self._last is None:
            return float(len(self.cpus))
        if os.getpid() != self._pid:  # a forked child: its CPU time starts afresh
            with self._lock:
                self._pid, self._last = os.getpid(), self._sample()
            return self.free
        now = self._clock()
        if now - self._last[0] < SAMPLE_S:
            return self.free
        with self._lock:
            if now - self._last[0] >= SAMPLE_S:
                new = self._sample()
                if new is not None:
                    wall = new[0] - self._last[0]
                    others = max((new[2] - self._last[2]) - (new[1] - self._last[1]), 0.0) / max(wall, 1e-9)
                    self.free = max(len(self.cpus) - others, 0.0)
                self._last = new
        return self.free

    def threads(self, cap: int) -> int:
        """Threads worth running now, at most ``cap``: the free cores, a core busy less than
        ``BUSY_SHARE`` of the time counted as free; at least one."""
        return max(1, min(cap, int(self.cores() + BUSY_SHARE)))


def _read_proc_stat() -> str:
    with open("/proc/stat", encoding="ascii") as f:
        return f.read()


try:
    _TICKS_PER_S = os.sysconf("SC_CLK_TCK")
except (AttributeError, ValueError, OSError):
    _TICKS_PER_S = 100

# measuring from import on, so that the first kernel call finds a window behind it
_free_cores = FreeCores() if ADAPT else None


def threads_to_use() -> int:
    """Threads for a threaded kernel called now: numba's thread count, less the cores other
    processes keep busy (see the module docstring)."""
    cap = numba.get_num_threads()
    if cap <= 1 or _free_cores is None:
        return cap
    return _free_cores.threads(cap)


class ThreadedKernel:
    """A kernel with a threaded and a serial compilation; call it like the kernel."""

    def __init__(self, fn, min_items: int | None = None, **options):
        self._own_min = None if min_items is None else int(min_items)
        self.threaded = njit(parallel=True, cache=True, **options)(fn)
        twin = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + "_serial", fn.__defaults__,
                                  fn.__closure__)
        twin.__qualname__ = fn.__qualname__ + "_serial"
        twin.__module__ = fn.__module__
        twin.__doc__ = fn.__doc__
        self.serial = njit(cache=True, **options)(twin)
        self.__doc__ = fn.__doc__
        self.__name__ = fn.__name__
        self.__wrapped__ = fn

    def min_items(self) -> int:
        """Rows from which the threaded kernel runs: the kernel's own threshold, unless
        ``CROWDMOTION_PARALLEL_MIN`` sets one for all; else ``PARALLEL_MIN_ITEMS``."""
        return PARALLEL_MIN_ITEMS if self._own_min is None or _MIN_FROM_ENV else self._own_min

    def __call__(self, *args):
        if len(args[0]) < self.min_items():
            return self.serial(*args)
        use = threads_to_use()
        if use == 1:
            return self.serial(*args)
        cap = numba.get_num_threads()
        if use == cap:
            return self.threaded(*args)
        numba.set_num_threads(use)
        try:
            return self.threaded(*args)
        finally:
            numba.set_num_threads(cap)


def threaded(fn=None, *, min_items: int | None = None, **options):
    """Decorator: ``fn`` as a :class:`ThreadedKernel` (write ``prange`` loops as usual);
    ``@threaded(min_items=n)`` threads from ``n`` rows on instead of ``PARALLEL_MIN_ITEMS``
    (for kernels whose rows cost microseconds each). Other keywords go to both
    compilations' ``njit`` (``error_model="numpy"``: a division by zero gives inf or NaN
    instead of raising, so that a loop dividing without branches can be vectorised)."""
    if fn is None:
        return lambda f: ThreadedKernel(f, min_items, **options)
    return ThreadedKernel(fn, **options)
