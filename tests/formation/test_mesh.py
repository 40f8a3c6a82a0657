"""Formation meshes: Delaunay triangles, the chain fallback, tearing and relinking."""

import warnings

import numpy as np
import pytest
from scipy.spatial import Delaunay

from crowdmotion.formation import templates
from crowdmotion.formation.mesh import FormationMesh, MeshFallbackWarning


def _triangle_set(tri):
    return {tuple(sorted(t)) for t in np.asarray(tri).tolist()}


def test_triangles_match_scipy_delaunay_for_points_in_general_position():
    p = np.random.default_rng(4).uniform(0, 20, size=(300, 2))
    mesh = FormationMesh(p)
    assert mesh.kind == "delaunay"
    assert _triangle_set(mesh.triangles) == _triangle_set(Delaunay(p).simplices)
    # counter-clockwise, and every edge of every triangle is stored once
    a, b, c = (p[mesh.triangles[:, k]] for k in range(3))
    assert np.all(((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]) > 0)
    pairs = {tuple(sorted(e)) for t in mesh.triangles for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert pairs == {tuple(e) for e in mesh.edges.tolist()}


@pytest.mark.parametrize("tpl", [templates.block(10, 10, 1.2), templates.wedge(6), templates.circle(24, 5.0),
                                 templates.cars(3, 4)])
def test_templates_mesh_every_agent(tpl):
    mesh = FormationMesh(tpl.points)
    assert mesh.kind == "delaunay"
    assert set(mesh.triangles.ravel()) == set(range(tpl.count))
    assert mesh.rest_length.min() > 0


def test_tearing_then_relinking_restores_the_original_triangles_exactly():
    mesh = FormationMesh(templates.block(6, 6, 1.0).points)
    original = mesh.triangles.copy()
    v = mesh.rest.copy()
    v[mesh.rest[:, 1] > 2.4, 1] += 4.0  # pull the left files away: the edges across the gap tear
    torn, relinked = mesh.update_tearing(v, tear_ratio=2.0, relink_ratio=1.5)
    assert torn > 0 and relinked == 0
    assert not mesh.active_elements.all()
    view = mesh.view(v)
    assert view.torn_triangles.any() and np.array_equal(view.triangles, original)
    torn, relinked = mesh.update_tearing(mesh.rest, tear_ratio=2.0, relink_ratio=1.5)
    assert relinked > 0 and not mesh.torn.any()
    assert mesh.active_elements.all()
    assert np.array_equal(mesh.triangles, original)
    assert np.array_equal(mesh.elements, original)


def test_collinear_points_fall_back_to_a_chain_and_say_so():
    with pytest.warns(MeshFallbackWarning, match="collinear"):
        mesh = FormationMesh(templates.line(7, 1.5).points)
    assert mesh.kind == "chain" and len(mesh.triangles) == 0
    assert len(mesh.edges) == 6 and len(mesh.elements) == 5
    with pytest.warns(MeshFallbackWarning, match="too few"):
        assert FormationMesh([[0.0, 0.0], [1.0, 0.0]]).kind == "chain"


def test_bad_point_sets_are_refused_by_name():
    with pytest.raises(ValueError, match="agents 0 and 2 share the position"):
        FormationMesh([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="position 1 is not finite"):
        FormationMesh([[0.0, 0.0], [np.nan, 0.0], [0.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        FormationMesh(templates.block(2, 2).points)  # a proper mesh gives no warning


def test_the_per_step_edge_error_kernel_agrees_with_the_metric():
    from crowdmotion.formation._kernels import edge_length_error as kernel
    from crowdmotion.metrics import edge_length_error

    mesh = FormationMesh(templates.block(6, 7, 1.1).points)
    moved = mesh.rest + np.random.default_rng(3).normal(scale=0.2, size=mesh.rest.shape)
    assert kernel(moved, mesh.edges, mesh.rest_length) == pytest.approx(
        edge_length_error(moved, mesh.rest, mesh.edges), rel=1e-12)
