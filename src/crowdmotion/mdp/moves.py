"""The action set of the grid MDP: 8 moves in 2D, 26 in 3D (paper §1.2), with their costs."""

from __future__ import annotations

from functools import lru_cache
from itertools import product

import numpy as np

PAD = 2
"""Blocked border width around every grid handed to a kernel (Algorithm 3 looks two
cells out for agents that a move could pass too close to)."""


@lru_cache(maxsize=None)
def move_offsets(dim: int) -> np.ndarray:
    """All unit moves of a ``dim``-dimensional grid, shape (3**dim - 1, dim), int64.

    The paper's action set A: 8 moves in 2D, 26 in 3D (8 at the same height, 9 above,
    9 below).
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    offs = [o for o in product((-1, 0, 1), repeat=dim) if any(o)]
    out = np.array(offs, dtype=np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=None)
def move_costs(dim: int) -> np.ndarray:
    """Euclidean length of each move in cells: 1, sqrt(2) or sqrt(3).

    The paper's reward for a free move is the negative of this length (§1.2, R).
    """
    out = np.sqrt(np.abs(move_offsets(dim)).sum(axis=1).astype(np.float64))
    out.setflags(write=False)
    return out


@lru_cache(maxsize=None)
def swept_offsets(dim: int) -> tuple[tuple[tuple[int, ...], ...], ...]:
    """For each move, the other cells its straight line sweeps past.

    A diagonal move touches every cell reached by a non-empty proper subset of its
    non-zero components (2 cells for a 2D diagonal, 2 or 6 for a 3D one). With corner
    cutting off, a move is allowed only if all of them are free.
    """
    result = []
    for off in move_offsets(dim):
        nz = [i for i in range(dim) if off[i] != 0]
        subs = []
        for mask in product((0, 1), repeat=len(nz)):
            if 0 < sum(mask) < len(nz):
                sub = [0] * dim
                for bit, axis in zip(mask, nz):
                    if bit:
                        sub[axis] = int(off[axis])
                subs.append(tuple(sub))
        result.append(tuple(subs))
    return tuple(result)


def flat_move_tables(
    strides: np.ndarray, corner_cutting: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flat-index move tables for a padded grid with the given flat ``strides``.

    Returns ``(offsets, costs, vectors, swept, swept_count)``: ``offsets[m]`` the flat
    offset of move m, ``costs[m]`` its length, ``vectors[m]`` its (dim,) vector,
    ``swept[m, :swept_count[m]]`` the flat offsets of the cells it sweeps past (none when
    corner cutting is allowed).
    """
    strides = np.asarray(strides, dtype=np.int64)
    dim = len(strides)
    offs = move_offsets(dim)
    flat = offs @ strides
    sw = swept_offsets(dim)
    width = max(len(s) for s in sw)
    swept = np.zeros((len(offs), width), dtype=np.int64)
    count = np.zeros(len(offs), dtype=np.int64)
    if not corner_cutting:
        for m, subs in enumerate(sw):
            for j, sub in enumerate(subs):
                swept[m, j] = int(np.dot(sub, strides))
            count[m] = len(subs)
    return flat, move_costs(dim).copy(), offs.astype(np.float64), swept, count


@lru_cache(maxsize=None)
def successor_moves(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """For each move a cell was reached by, the moves worth relaxing from it.

    A cell x reached from p by move a need not relax a neighbour y that is also next to
    p (or is p): p was expanded first and offered y the cost d(p) + |y - p|, which is
    strictly less than d(p) + |a| + |y - x| (triangle inequality; equality would need
    two parallel moves, whose sum is not a move). So from x only moves b with
    max|a + b| = 2, i.e. sharing a non-zero component with a, can improve anything:
    3 or 5 of 8 in 2D, 9, 15 or 19 of 26 in 3D. The pruned relaxations can never
    succeed, so the distances are bit-identical to the unpruned search.

    Returns ``(table, count)``: ``table[a, :count[a]]`` are the move indices kept after
    move ``a``.
    """
    offs = move_offsets(dim)
    n = len(offs)
    table = np.zeros((n, n), dtype=np.int64)
    count = np.zeros(n, dtype=np.int64)
    for a in range(n):
        keep = [b for b in range(n) if np.max(np.abs(offs[a] + offs[b])) == 2]
        table[a, : len(keep)] = keep
        count[a] = len(keep)
    table.setflags(write=False)
    count.setflags(write=False)
    return table, count


def crossing_masks(near: np.ndarray, vectors: np.ndarray, min_sep_sq: float) -> np.ndarray:
    """For Algorithm 3's crossing test: which own moves pass too close to a neighbour.

    ``masks[q, d]`` (int64) has bit m set when an agent moving by ``vectors[m]`` comes
    closer than ``sqrt(min_sep_sq)`` to one that starts at the relative cell ``near[q]``
    and moves by ``vectors[d]`` (d = len(vectors): stays), both in straight lines over
    the step: the least of |w + t·d|² over t in [0, 1], w = −near[q], d = vectors[m] −
    vectors[d]. One table per radius replaces the per-pair geometry in the step loop;
    built once per run, with numpy.
    """
    near = np.asarray(near, np.float64)
    vectors = np.asarray(vectors, np.float64)
    other = np.vstack([vectors, np.zeros((1, vectors.shape[1]))])
    w = -near[:, None, None, :]  # (q, 1, 1, dim)
    d = vectors[None, None, :, :] - other[None, :, None, :]  # (1, other, own, dim)
    w2 = np.zeros((len(near), 1, 1))
    wd = np.zeros(w.shape[:1] + d.shape[1:3])
    dd = np.zeros(d.shape[:3])
    for k in range(near.shape[1]):  # axis by axis, as the sums were always added up
        w2 = w2 + w[..., k] * w[..., k]
        wd = wd + w[..., k] * d[..., k]
        dd = dd + d[..., k] * d[..., k]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dd > 0.0, np.clip(-wd / dd, 0.0, 1.0), 0.0)
    close = w2 + 2.0 * t * wd + t * t * dd < min_sep_sq  # (q, other, own)
    return (close.astype(np.int64) << np.arange(len(vectors), dtype=np.int64)).sum(axis=2)
