"""Shared numeric helpers: argument checks and closest approach of linear motions."""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike


def plain(value):
    """``value`` with numpy arrays and scalars as plain lists and numbers, for messages
    (``[1.0, nan]``, not ``array([ 1., nan])`` or ``np.float64(1.0)``)."""
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return type(value)(plain(v) for v in value)
    return value


def row_norms(v: np.ndarray) -> np.ndarray:
    """(N,) the length of each row of an (N, 2) array: ``np.linalg.norm(v, axis=1)``, the
    same numbers in a third of the time (the per-step paths take several a step)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1])


def box_of(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners of the (N, 2) ``points``' bounding box, column by column:
    ``points.min(axis=0)`` and ``max`` reduce across the short axis, 30 times slower."""
    x, y = points[:, 0], points[:, 1]
    return np.array([x.min(), y.min()]), np.array([x.max(), y.max()])


def finite_number(value) -> bool:
    """Whether ``value`` is one finite real number: not a bool, a string or a list (numpy's
    isfinite refuses a string with a TypeError that names nothing)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and bool(np.isfinite(value))


def finite_array(value, name: str, dtype=float) -> np.ndarray:
    """``value`` as a numpy array, or a ValueError naming ``name`` if any entry is NaN/inf."""
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {plain(value)!r}") from exc
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite numbers, got {plain(value)!r}")
    return arr


def require_finite_agents(arrays: Mapping[str, ArrayLike], active: ArrayLike | None = None,
                          ids: Sequence | None = None) -> None:
    """A ValueError naming the array, the first agent (and frame) and the value, if any
    agent's entry in ``arrays`` is NaN or inf: ``positions of agent 0 is not finite: nan``.

    Each array is (N, D), one row per agent, or (T, N, D), per frame and agent (the
    frame is named too). ``active``: (N,) or (T, N), only those entries are checked
    (default all). ``ids``: the agents' names in the message (default their index).
    Kernels compiled with numba must never see such a value: they may crash the process.
    """
    for name, values in arrays.items():
        v = np.asarray(values, dtype=float)
        if np.isfinite(v).all():  # the usual case, checked at once (a step calls this every time)
            continue
        ok = np.isfinite(v).all(axis=-1)
        if active is not None:
            ok |= ~np.asarray(active, dtype=bool)
        if ok.all():
            continue
        where = tuple(int(k) for k in np.argwhere(~ok)[0])
        agent = where[-1] if ids is None else ids[where[-1]]
        frame = f" at frame {where[0]}" if len(where) == 2 else ""
        row = v[where]
        raise ValueError(f"{name} of agent {agent}{frame} is not finite: {float(row[~np.isfinite(row)][0])}")


def positive_number(value, name: str) -> float:
    """``value`` as a finite float above zero, or a ValueError naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {plain(value)!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive number, got {plain(value)!r}")
    return v


def as_points(points, dim: int) -> np.ndarray:
    """``points`` as a float array whose last axis has length ``dim``."""
    p = np.asarray(points, dtype=float)
    if p.shape[-1:] != (dim,):
        raise ValueError(f"points must have {dim} coordinates on the last axis, got shape {p.shape}")
    return p


def closest_approach(w0: np.ndarray, dw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least distance of ``w0 + t * dw`` over t in [0, 1], and the t where it occurs.

    ``w0`` and ``dw`` are (..., D): the relative position at the start of an interval
    and its change over the interval. Closed form: t* = clamp(-w0.dw / |dw|^2, 0, 1).
    """
    dd = np.einsum("...k,...k->...", dw, dw)
    wd = np.einsum("...k,...k->...", w0, dw)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dd > 0, np.clip(-wd / np.where(dd > 0, dd, 1.0), 0.0, 1.0), 0.0)
    closest = w0 + t[..., None] * dw
    return np.linalg.norm(closest, axis=-1), t


def minimise_convex_on_segment(
    f: Callable[[np.ndarray], np.ndarray], n: int, iterations: int = 60
) -> tuple[np.ndarray, np.ndarray]:
    """Golden-section minimum over t in [0, 1] of a convex function, for n segments at once.

    ``f(t)`` takes a (n,) array of parameters and returns (n,) values. Used for the
    distance from a moving point to a convex shape, which is convex in t.
    Returns (min value, argmin t); 60 iterations narrow t to ~3e-13.
    """
    g = (np.sqrt(5.0) - 1.0) / 2.0
    a = np.zeros(n)
    b = np.ones(n)
    for _ in range(iterations):
        c = b - g * (b - a)
        d = a + g * (b - a)
        left = f(c) < f(d)
        b = np.where(left, d, b)
        a = np.where(left, a, c)
    t = (a + b) / 2
    ends = np.stack([f(np.zeros(n)), f(t), f(np.ones(n))])
    best = np.argmin(ends, axis=0)
    t_best = np.choose(best, [np.zeros(n), t, np.ones(n)])
    return ends[best, np.arange(n)], t_best
