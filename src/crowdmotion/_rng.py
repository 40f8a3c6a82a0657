"""Counter-based random numbers for numba kernels: the same seed gives the same draws
whatever the number of threads, because each draw is a pure function of
(key, index, draw number) — SplitMix64 of a combined counter."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(inline="always")
def mix64(z):
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(inline="always")
def uniform(key, i, k):
    """U[0, 1) from (key, item i, draw k)."""
    z = mix64(key ^ (np.uint64(i) * np.uint64(0x9E3779B97F4A7C15)))
    z = mix64(z ^ (np.uint64(k) * np.uint64(0xD1B54A32D192ED03) + np.uint64(0x632BE59BD9B4E019)))
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def step_key(rng: np.random.Generator) -> np.uint64:
    """A fresh 64-bit key for one step's draws, from the run's numpy Generator."""
    return np.uint64(rng.integers(0, 2**63 - 1, dtype=np.int64))


def _mix64_array(z: np.ndarray) -> np.ndarray:
    """:func:`mix64` over a uint64 array (numpy wraps uint64 arithmetic modulo 2⁶⁴)."""
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def uniforms(key, items, k: int) -> np.ndarray:
    """:func:`uniform` for many items at once, in numpy (no compilation): U[0, 1) from
    (key, each of ``items``, draw ``k``), the same numbers the kernels would draw."""
    with np.errstate(over="ignore"):
        i = np.atleast_1d(np.asarray(items)).astype(np.uint64)
        z = _mix64_array(np.uint64(key) ^ (i * np.uint64(0x9E3779B97F4A7C15)))
        z = _mix64_array(z ^ np.full_like(i, np.uint64(k) * np.uint64(0xD1B54A32D192ED03) + np.uint64(0x632BE59BD9B4E019)))
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)
