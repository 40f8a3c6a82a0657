"""Two-step ARAP against closed forms and an independent dense least-squares solve."""

import numpy as np
import pytest
import scipy.sparse as sp

from crowdmotion.formation import templates
from crowdmotion.formation.arap import ARAPSolver
from crowdmotion.formation.mesh import FormationMesh


def _rigid(points, angle, shift):
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, -s], [s, c]]).T + shift


@pytest.mark.filterwarnings("ignore::crowdmotion.formation.mesh.MeshFallbackWarning")
@pytest.mark.parametrize("variant", ["two_step", "average"])
@pytest.mark.parametrize("pts", [templates.block(8, 9, 1.1).points, templates.wedge(5).points,
                                 templates.circle(16, 4.0).points, templates.line(9).points,
                                 np.random.default_rng(2).uniform(-5, 5, (60, 2))])
def test_moving_all_handles_rigidly_moves_the_whole_mesh_rigidly(pts, variant):
    mesh = FormationMesh(pts)
    solver = ARAPSolver(mesh)
    handles = np.array([0, len(pts) // 2, len(pts) - 1])
    want = _rigid(mesh.rest, 0.83, np.array([12.0, -7.5]))
    got = solver.deform(handles, want[handles], variant=variant)
    assert np.abs(got - want).max() < 1e-9


def procrustes_fit(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The congruent copies of ``rest`` elements (e, k) nearest to ``current`` (e, k),
    both complex: rotation (no reflection) and translation, least squares."""
    cr = rest.mean(axis=1, keepdims=True)
    cz = current.mean(axis=1, keepdims=True)
    s = np.sum(np.conj(rest - cr) * (current - cz), axis=1, keepdims=True)
    mag = np.abs(s)
    rot = np.where(mag > 0, s / np.where(mag > 0, mag, 1.0), 1.0)
    return cz + rot * (rest - cr)


def _dense_two_step(rest, tri, handles, q, W):
    """The two energies built from their definitions and solved by dense lstsq."""
    n = len(rest)
    rz = rest[:, 0] + 1j * rest[:, 1]
    rows = []
    for a, b, c in tri:
        for i0, i1, i2 in ((a, b, c), (b, c, a), (c, a, b)):
            w = (rz[i2] - rz[i0]) / (rz[i1] - rz[i0])
            r = np.zeros(n, complex)
            r[i2], r[i0], r[i1] = 1, -(1 - w), -w
            rows.append(r)
    M = np.array(rows)
    hw = np.sqrt(W)
    C = np.zeros((len(handles), n), complex)
    C[np.arange(len(handles)), handles] = hw
    qz = q[:, 0] + 1j * q[:, 1]
    z1 = np.linalg.lstsq(np.vstack([M, C]), np.concatenate([np.zeros(len(M)), hw * qz]), rcond=None)[0]
    fitted = procrustes_fit(rz[tri], z1[tri])
    rows, rhs = [], []
    for t, f in zip(tri, fitted):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            r = np.zeros(n)
            r[t[a]], r[t[b]] = 1, -1
            rows.append(r)
            rhs.append(f[a] - f[b])
    A = np.vstack([np.array(rows), C.real])
    z = np.linalg.lstsq(A, np.concatenate([np.array(rhs), hw * qz]), rcond=None)[0]
    return np.stack([z.real, z.imag], axis=1)


def test_two_step_equals_a_dense_least_squares_solve_of_both_energies():
    mesh = FormationMesh(templates.block(5, 6, 1.0).points)
    handles = np.array([0, 7, 29])
    q = mesh.rest[handles] + np.array([[0.0, 0.0], [1.5, -0.8], [-2.0, 3.0]])
    got = ARAPSolver(mesh, handle_weight=50.0).deform(handles, q)
    want = _dense_two_step(mesh.rest, mesh.triangles, handles, q, 50.0)
    assert np.abs(got - want).max() < 1e-8


def test_factorisations_are_cached_per_handle_set_and_topology():
    mesh = FormationMesh(templates.block(6, 6, 1.0).points)
    solver = ARAPSolver(mesh, anchor_weight=0.01)
    anchor = mesh.rest + 0.5
    for _ in range(3):
        solver.deform([0, 5], mesh.rest[[0, 5]], anchor)
    assert solver.stats == {"factorisations": 1, "cache_hits": 2}
    solver.deform([0, 6], mesh.rest[[0, 6]], anchor)
    assert solver.stats["factorisations"] == 2
    v = mesh.rest.copy()
    v[0] += [10.0, 0.0]
    mesh.update_tearing(v, 2.0, 1.5)  # a new topology
    solver.deform([0, 5], mesh.rest[[0, 5]], anchor)
    assert solver.stats["factorisations"] == 3


def test_fewer_than_two_handles_need_an_anchor():
    mesh = FormationMesh(templates.block(3, 3).points)
    with pytest.raises(ValueError, match="at least two handles"):
        ARAPSolver(mesh).deform([0], mesh.rest[[0]])
    # with an anchor and no handle, a rigidly moved anchor is reproduced exactly
    want = _rigid(mesh.rest, -0.4, np.array([3.0, 1.0]))
    got = ARAPSolver(mesh, anchor_weight=0.05).deform([], np.zeros((0, 2)), anchor=want)
    assert np.abs(got - want).max() < 1e-9


@pytest.mark.parametrize("anchor_weight", [0.0, 0.01])  # 0: a bare vertex has no diagonal: built anew
def test_a_new_handle_set_reuses_its_topologys_layout_and_gets_the_same_matrices(anchor_weight):
    mesh = FormationMesh(templates.block(6, 7, 1.0).points)
    v = mesh.rest.copy()
    v[0] += [10.0, 0.0]
    mesh.update_tearing(v, 2.0, 1.5)  # some edges torn: elements drop out of both systems
    assert mesh.torn.any()
    solver = ARAPSolver(mesh, anchor_weight=anchor_weight)
    active = mesh.active_elements
    rng = np.random.default_rng(5)
    for k in (2, 5, 9, 9, 42):
        handles = np.sort(rng.choice(mesh.n_vertices, k, replace=False))
        diag = solver._diag(handles)
        got = solver._systems(handles)
        fresh = (sp.triu(solver._step1_matrix(active, diag), format="csc"),
                 sp.triu(solver._step2_matrix(active, diag), format="csc"))
        for g, f in zip(got, fresh):
            assert g.shape == f.shape and (g != f).nnz == 0  # the same numbers, bit for bit
    assert len(solver._layouts) == 1
