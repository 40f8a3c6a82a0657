"""Two-step as-rigid-as-possible deformation of the formation mesh (§2.2; Igarashi,
Moscovich & Hughes 2005), with factorisations cached per (topology, handle set).

Vertices are complex numbers z = x + iy. Every element (a triangle, or a triple of a
chain) fixes each of its vertices in the frame of the opposite edge: z2 − z0 = w·(z1 − z0)
with w the rest triangle's local coordinates (x + iy). Step 1 (scale-free construction)
minimises the sum of |z2 − (1 − w) z0 − w z1|² over every element and vertex; it is
invariant to rotation, translation and uniform scale. Step 2 (scale adjustment) fits to
each intermediate element the congruent copy of its rest element nearest to it (a
rotation and a translation: Procrustes) and minimises eq. (1),
E = Σ ‖(v″i − v″j) − (v′i − v′j)‖² over the elements' edges.

Handles are soft constraints W·|z − q|² (Igarashi's formulation); every vertex also has a
weak pull ε·|z − p|² to an anchor p (where the attraction alone would take it), which
keeps each system positive definite with fewer than two handles and after tearing
splits the mesh. With ε = 0 and at least two handles on a connected mesh it is the plain
method. Step 1's Hermitian system is solved in its real form [[A, −B], [B, A]]; both are
factored with QDLDL (sparse LDLᵀ) once per (torn-edge set, handle set) and kept in a small
cache, so a step costs only right-hand sides and back-substitutions.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import qdldl
import scipy.sparse as sp

from crowdmotion.formation._kernels import fit_elements
from crowdmotion.formation.mesh import FormationMesh

ROLES = ((0, 1, 2), (1, 2, 0), (2, 0, 1))


class ARAPSolver:
    """As-rigid-as-possible deformation of one formation mesh.

    >>> solver = ARAPSolver(mesh)
    >>> z = solver.deform(handles, targets)                 # doctest: +SKIP
    """

    def __init__(self, mesh: FormationMesh, handle_weight: float = 1000.0, anchor_weight: float = 0.0,
                 cache_size: int = 16):
        self.mesh = mesh
        self.W = float(handle_weight)
        self.eps = float(anchor_weight)
        rest = mesh.rest[:, 0] + 1j * mesh.rest[:, 1]
        self.rest_z = rest
        el = mesh.elements
        self._rows = []  # per role: (i0, i1, i2, w) for every element
        for r0, r1, r2 in ROLES:
            i0, i1, i2 = el[:, r0], el[:, r1], el[:, r2]
            w = (rest[i2] - rest[i0]) / (rest[i1] - rest[i0]) if len(el) else np.zeros(0, complex)
            self._rows.append((i0, i1, i2, w))
        self._cache: OrderedDict = OrderedDict()
        self._layouts: OrderedDict = OrderedDict()  # per torn-edge set: see _systems
        self.cache_size = cache_size
        self.stats = {"factorisations": 0, "cache_hits": 0}

    def __getstate__(self) -> dict:
        """Pickled without the factorisation and layout caches (qdldl's solvers do not
        pickle); the copy rebuilds them as it deforms."""
        state = self.__dict__.copy()
        state["_cache"], state["_layouts"] = OrderedDict(), OrderedDict()
        return state

    # ---- systems ------------------------------------------------------------------------
    def _diag(self, handles: np.ndarray) -> np.ndarray:
        d = np.full(self.mesh.n_vertices, self.eps)
        d[handles] += self.W
        return d

    def _step1_hermitian(self, active: np.ndarray) -> sp.csc_matrix:
        """Step 1's Hermitian form MᴴM over the active elements, without the handle and
        anchor weights."""
        n = self.mesh.n_vertices
        rows, cols, vals = [], [], []
        k = 0
        for i0, i1, i2, w in self._rows:
            i0, i1, i2, w = i0[active], i1[active], i2[active], w[active]
            r = k + np.arange(len(w))
            rows += [r, r, r]
            cols += [i2, i0, i1]
            vals += [np.ones(len(w), complex), -(1 - w), -w]
            k += len(w)
        M = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(k, n))
        return (M.conj().T @ M).tocsc()

    def _step1_matrix(self, active: np.ndarray, diag: np.ndarray, hermitian=None) -> sp.csc_matrix:
        H = (self._step1_hermitian(active) if hermitian is None else hermitian) + sp.diags(diag)
        A, B = H.real, H.imag
        return sp.bmat([[A, -B], [B, A]], format="csc")

    def _step2_laplacian(self, active: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """Step 2's graph Laplacian over the active elements' edges: (degrees, adjacency)."""
        n = self.mesh.n_vertices
        el = self.mesh.elements[active]
        i = np.concatenate([el[:, 0], el[:, 1], el[:, 2]])
        j = np.concatenate([el[:, 1], el[:, 2], el[:, 0]])
        adj = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
        adj = (adj + adj.T).tocsr()
        return np.asarray(adj.sum(axis=1)).ravel(), adj

    def _step2_matrix(self, active: np.ndarray, diag: np.ndarray, laplacian=None) -> sp.csc_matrix:
        deg, adj = self._step2_laplacian(active) if laplacian is None else laplacian
        return (sp.diags(deg + diag) - adj).tocsc()

    def _systems(self, handles: np.ndarray) -> tuple[sp.csc_matrix, sp.csc_matrix]:
        """The upper triangles (CSC) of step 1's real system and step 2's system for
        ``handles``. Only their diagonals depend on the handles: the first handle set of a
        torn-edge set builds both matrices; later ones copy that layout and write the
        diagonal (the part of MᴴM or the degrees, plus the weights; the same sums, so the
        same numbers, as building them anew, for a tenth of the time)."""
        key = np.packbits(self.mesh.torn).tobytes()
        diag = self._diag(handles)
        layout = self._layouts.get(key)
        if layout is None:
            active = self.mesh.active_elements
            hermitian, laplacian = self._step1_hermitian(active), self._step2_laplacian(active)
            first = (sp.triu(self._step1_matrix(active, diag, hermitian), format="csc"),
                     sp.triu(self._step2_matrix(active, diag, laplacian), format="csc"))
            bases = (np.tile(hermitian.diagonal().real, 2), laplacian[0])
            layout = [(m, _diagonal_slots(m), base) for m, base in zip(first, bases)]
            self._layouts[key] = layout
            if len(self._layouts) > self.cache_size:
                self._layouts.popitem(last=False)
            return first
        self._layouts.move_to_end(key)
        out = []
        for (m, slots, base), weights in zip(layout, (np.tile(diag, 2), diag)):
            if slots is None:  # a zero on a diagonal left it out of the layout: build anew
                active = self.mesh.active_elements
                build = self._step1_matrix if len(out) == 0 else self._step2_matrix
                out.append(sp.triu(build(active, diag), format="csc"))
                continue
            data = m.data.copy()
            data[slots] = base + weights
            out.append(sp.csc_matrix((data, m.indices, m.indptr), shape=m.shape))
        return out[0], out[1]

    def _factors(self, handles: np.ndarray):
        n = self.mesh.n_vertices
        every = len(handles) == n  # handles are unique and sorted: all of them
        key = (np.packbits(self.mesh.torn).tobytes(), "all" if every else handles.tobytes())
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            self.stats["cache_hits"] += 1
            return hit
        step1, step2 = self._systems(handles)
        el = self.mesh.elements[self.mesh.active_elements]
        f = (qdldl.Solver(step1), qdldl.Solver(step2), el, self.rest_z[el])
        self.stats["factorisations"] += 1
        self._cache[key] = f
        if len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return f

    # ---- the two steps -----------------------------------------------------------------
    def deform(self, handles, targets, anchor=None, variant: str = "two_step") -> np.ndarray:
        """Vertex positions (n, 2) minimising the two-step energy with ``handles`` (indices)
        pulled to ``targets`` (h, 2) and every vertex weakly to ``anchor`` (n, 2).

        ``variant = "average"`` ends step 2 with the mean of the fitted elements' proposed
        positions instead of the eq. (1) solve (the paper's cheap variant).
        """
        n = self.mesh.n_vertices
        handles = np.asarray(handles, np.int64)
        if len(handles) and (np.any(np.diff(handles) <= 0) or handles[0] < 0 or handles[-1] >= n):
            order = np.unique(handles, return_index=True)[1]
            if len(order) != len(handles) or handles.min() < 0 or handles.max() >= n:
                raise ValueError(f"arap: handles must be distinct vertex indices in [0, {n}), got {handles.tolist()}")
            handles, targets = handles[order], np.asarray(targets, float).reshape(-1, 2)[order]
        q = np.asarray(targets, float).reshape(len(handles), 2)
        if self.eps == 0 and len(handles) < 2:
            raise ValueError(f"arap: at least two handles are needed without an anchor, got {len(handles)}")
        if anchor is None:
            if self.eps > 0:
                raise ValueError("arap: an anchor is needed when anchor_weight > 0")
            anchor = np.zeros((n, 2))
        p = np.asarray(anchor, float)
        F1, F2, el, rest = self._factors(handles)  # with the active elements and their rest shapes
        pz = p[:, 0] + 1j * p[:, 1]
        rhs = self.eps * pz
        rhs[handles] += self.W * (q[:, 0] + 1j * q[:, 1])
        x = F1.solve(np.concatenate([rhs.real, rhs.imag]))
        z1 = x[:n] + 1j * x[n:]
        if len(el) == 0:
            return np.stack([z1.real, z1.imag], axis=1)
        if variant == "average":  # the mean of the positions the fitted elements propose
            sums, counts = np.zeros(n, complex), np.zeros(n)
            fit_elements(rest, z1, el, sums, sums, counts, False)
            z = np.where(counts > 0, sums / np.maximum(counts, 1), z1)
            z[handles] = z1[handles]
            return np.stack([z.real, z.imag], axis=1)
        b = rhs.copy()  # step 2: fit (2a) and eq. (1)'s normal equations (2b)
        fit_elements(rest, z1, el, b, b, np.zeros(0), True)
        return np.stack([F2.solve(b.real), F2.solve(b.imag)], axis=1)


def _diagonal_slots(upper: sp.csc_matrix) -> np.ndarray | None:
    """Where each diagonal entry of an upper-triangular CSC matrix sits in its ``data``
    (the last entry of its column, indices sorted), or None if one is missing."""
    upper.sort_indices()
    last = upper.indptr[1:] - 1
    n = upper.shape[1]
    if upper.nnz == 0 or np.any(last < upper.indptr[:-1]) or np.any(upper.indices[np.maximum(last, 0)] != np.arange(n)):
        return None
    return last
