"""The formation mesh (§2.1): a Delaunay triangulation of the group's rest positions,
with the rest edges stored so that torn edges can be relinked without re-triangulating."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import triangle
from scipy.spatial import cKDTree

COLLINEAR_TOL = 1e-9


class MeshFallbackWarning(UserWarning):
    """A point set with no triangles (fewer than three points, or all on one line)."""


@dataclass(frozen=True)
class MeshView:
    """The mesh as it stands: ``vertices`` (n, 2), ``edges`` (m, 2), ``triangles`` (t, 3),
    ``torn_edges`` (m,) and ``torn_triangles`` (t,) flags; ``kind`` "delaunay" or "chain"."""

    vertices: np.ndarray
    edges: np.ndarray
    triangles: np.ndarray
    torn_edges: np.ndarray
    torn_triangles: np.ndarray
    kind: str


def check_points(rest: np.ndarray, what: str = "formation") -> np.ndarray:
    """Rest positions as a finite (n, 2) float array with no two points at one place."""
    p = np.asarray(rest, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0:
        raise ValueError(f"{what}: positions must be a non-empty (n, 2) array, got shape {p.shape}")
    if not np.isfinite(p).all():
        bad = int(np.flatnonzero(~np.isfinite(p).all(axis=1))[0])
        raise ValueError(f"{what}: position {bad} is not finite: {p[bad].tolist()}")
    scale = max(float(np.ptp(p, axis=0).max()), 1.0)
    pairs = cKDTree(p).query_pairs(scale * 1e-9, output_type="ndarray")
    if len(pairs):
        i, j = (int(v) for v in pairs[0])
        raise ValueError(f"{what}: agents {i} and {j} share the position {p[i].tolist()} "
                         f"({len(pairs)} duplicate pair(s)); a formation needs distinct positions")
    return p


class FormationMesh:
    """Delaunay mesh of rest positions; elements, edges and the tearing state.

    ``triangles`` are the Delaunay triangles (empty for a chain). ``elements`` are what
    the deformation works on: the triangles, or for collinear points (no triangles) the
    consecutive triples of the chain along the line, said in ``kind = "chain"`` and with
    a :class:`MeshFallbackWarning`. ``element_edges`` (e, 3) index ``edges``; an element
    takes part in the deformation while none of its edges is torn.
    """

    def __init__(self, rest, what: str = "formation", warn: bool = True):
        p = check_points(rest, what)
        self.rest = p
        n = len(p)
        centred = p - p.mean(axis=0)
        sv = np.linalg.svd(centred, compute_uv=False) if n >= 2 else np.zeros(2)
        collinear = n < 3 or sv[1] <= COLLINEAR_TOL * max(sv[0], 1e-300)
        if collinear:
            self.kind = "chain"
            axis = np.linalg.svd(centred)[2][0] if n >= 2 else np.array([1.0, 0.0])
            order = np.argsort(centred @ axis, kind="stable")
            self.triangles = np.zeros((0, 3), np.int64)
            chain = np.stack([order[:-1], order[1:]], axis=1)
            self.elements = np.stack([order[:-2], order[1:-1], order[2:]], axis=1) if n >= 3 else \
                np.zeros((0, 3), np.int64)
            self.edges = np.sort(chain, axis=1).astype(np.int64)
            m = len(self.edges)
            self.element_edges = np.stack([np.arange(m - 1), np.arange(1, m), np.arange(1, m)], axis=1) \
                if m >= 2 else np.zeros((0, 3), np.int64)
            if warn and n >= 2:  # one agent needs no mesh: nothing to say
                warnings.warn(f"{what}: the {n} positions are {'too few' if n < 3 else 'collinear'} for "
                              "triangles; the mesh falls back to a chain along the line", MeshFallbackWarning,
                              stacklevel=2)
        else:
            self.kind = "delaunay"
            out = triangle.triangulate({"vertices": p}, "Q")
            tri = np.asarray(out["triangles"], np.int64)
            if len(out["vertices"]) != n:  # pragma: no cover - triangle adds no points without q/a flags
                raise RuntimeError("triangulation added vertices")
            # counter-clockwise, so that each element's local frame has a consistent side
            a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
            cw = ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]) < 0
            tri[cw] = tri[cw][:, [0, 2, 1]]
            self.triangles = self.elements = tri
            a, b = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2]]), np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0]])
            keys, inverse = np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_inverse=True)
            self.edges = np.stack([keys // n, keys % n], axis=1)
            self.element_edges = inverse.reshape(3, -1).T.astype(np.int64)
        self.rest_length = np.linalg.norm(p[self.edges[:, 0]] - p[self.edges[:, 1]], axis=1)
        self.torn = np.zeros(len(self.edges), dtype=bool)
        self.version = 0  # bumped at every tear or relink: the deformation's cache key

    @property
    def n_vertices(self) -> int:
        return len(self.rest)

    @property
    def active_elements(self) -> np.ndarray:
        """(e,) elements none of whose edges is torn."""
        if len(self.elements) == 0:
            return np.zeros(0, dtype=bool)
        return ~self.torn[self.element_edges].any(axis=1)

    def edge_ratio(self, vertices: np.ndarray) -> np.ndarray:
        """Each edge's current length over its rest length."""
        v = np.asarray(vertices, float)
        return np.linalg.norm(v[self.edges[:, 0]] - v[self.edges[:, 1]], axis=1) / self.rest_length

    def update_tearing(self, vertices: np.ndarray, tear_ratio: float, relink_ratio: float) -> tuple[int, int]:
        """Tear edges stretched beyond ``tear_ratio`` × rest length; relink torn edges back
        within ``relink_ratio`` × (their triangles come back from the stored rest mesh).
        Returns (torn now, relinked now)."""
        ratio = self.edge_ratio(vertices)
        tear = ~self.torn & (ratio > tear_ratio)
        relink = self.torn & (ratio <= relink_ratio)
        if tear.any() or relink.any():
            self.torn = (self.torn | tear) & ~relink
            self.version += 1
        return int(tear.sum()), int(relink.sum())

    def view(self, vertices: np.ndarray) -> MeshView:
        """The mesh at ``vertices`` with its tearing flags."""
        torn_tri = self.torn[self.element_edges].any(axis=1) if self.kind == "delaunay" else np.zeros(0, bool)
        return MeshView(np.array(vertices, float), self.edges.copy(), self.triangles.copy(), self.torn.copy(),
                        torn_tri, self.kind)
