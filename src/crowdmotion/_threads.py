"""Kernels that use threads only where they pay: ``@threaded`` compiles a numba kernel
twice on demand, with ``parallel=True`` for large inputs and without for small ones.

A parallel region costs tens of microseconds a step, and compiling one costs seconds on
a fresh install (numba's parfor passes): for a scene of a few hundred agents both are
waste. ``@threaded`` gives a callable that runs the serial twin when the first argument
has fewer than ``PARALLEL_MIN_ITEMS`` rows (or numba has one thread) and the threaded
kernel otherwise; only the one a run uses is compiled. ``CROWDMOTION_PARALLEL_MIN``
overrides the threshold (0: always threaded).

The twin is a copy of the Python function under another name, so the two keep separate
entries in numba's on-disk cache.
"""

from __future__ import annotations

import os
import types

import numba
from numba import njit

PARALLEL_MIN_ITEMS = int(os.environ.get("CROWDMOTION_PARALLEL_MIN", "1000"))


class ThreadedKernel:
    """A kernel with a threaded and a serial compilation; call it like the kernel."""

    def __init__(self, fn):
        self.threaded = njit(parallel=True, cache=True)(fn)
        twin = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + "_serial", fn.__defaults__,
                                  fn.__closure__)
        twin.__qualname__ = fn.__qualname__ + "_serial"
        twin.__module__ = fn.__module__
        twin.__doc__ = fn.__doc__
        self.serial = njit(cache=True)(twin)
        self.__doc__ = fn.__doc__
        self.__name__ = fn.__name__
        self.__wrapped__ = fn

    def __call__(self, *args):
        small = len(args[0]) < PARALLEL_MIN_ITEMS or numba.get_num_threads() == 1
        return (self.serial if small else self.threaded)(*args)


def threaded(fn) -> ThreadedKernel:
    """Decorator: ``fn`` as a :class:`ThreadedKernel` (write ``prange`` loops as usual)."""
    return ThreadedKernel(fn)
