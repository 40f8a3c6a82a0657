"""PSO kernels against closed forms and independent references: the redirect rule
(eqs. 4-5 with numpy's cross product), segment clearance (brute force), the grid (cKDTree)."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from crowdmotion.pso import _kernels as K
from crowdmotion.pso.params import PSOParams


def _redirect(k, u, r1=0.3, r2=0.7):
    out = np.empty(len(k))
    deg = K.redirect(np.asarray(k, float), np.asarray(u, float), r1, r2, out)
    return out, deg


@pytest.mark.parametrize("seed", range(5))
def test_redirect_is_eq4_eq5_in_3d(seed):
    rng = np.random.default_rng(seed)
    k, u = rng.normal(size=3), rng.normal(size=3)
    out, deg = _redirect(k, u)
    i = np.cross(k, u)  # eq. (4)
    m = np.cross(u, i)  # eq. (5)
    expected = np.linalg.norm(k) * m / np.linalg.norm(m)
    assert not deg
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-12)
    assert abs(out @ u) < 1e-12  # perpendicular to u
    assert out @ k > 0  # on k's side: the least change of direction


def test_redirect_2d_is_the_perpendicular_on_ks_side():
    out, deg = _redirect([1.0, 1.0], [1.0, 0.0])  # obstacle ahead on x, step goes up-right
    assert not deg
    np.testing.assert_allclose(out, [0.0, np.sqrt(2.0)])
    out, _ = _redirect([1.0, -0.5], [1.0, 0.0])
    np.testing.assert_allclose(out, [0.0, -np.hypot(1.0, 0.5)])


@pytest.mark.parametrize("dim", [2, 3])
def test_redirect_head_on_picks_a_random_perpendicular(dim):
    u = np.zeros(dim)
    u[0] = 2.0
    k = 0.5 * u  # straight at the obstacle's centre: k x u = 0
    sides = set()
    for r1 in np.linspace(0.05, 0.95, 7):
        out, deg = _redirect(k, u, r1, 0.4)
        assert deg
        assert abs(out @ u) < 1e-12
        assert np.linalg.norm(out) == pytest.approx(np.linalg.norm(k))
        sides.add(tuple(np.sign(np.round(out[1:], 9))))
    assert len(sides) >= 2  # both ways round, depending on the draw


def test_redirected_step_never_enters_the_obstacle():
    # the move is perpendicular to the direction of the nearest point: clearance cannot shrink
    rng = np.random.default_rng(3)
    sc, sr = np.array([[0.0, 0.0, 0.0]]), np.array([2.0])
    empty = np.empty((0, 3))
    tmp = np.empty(3)
    for _ in range(200):
        d = rng.normal(size=3)
        p = d / np.linalg.norm(d) * rng.uniform(2.3, 4.0)
        k = -p / np.linalg.norm(p) * 0.8 + rng.normal(scale=0.3, size=3)
        out, _ = _redirect(k, sc[0] - p, *rng.uniform(size=2))
        assert K.segment_clear(p, out, 0.25, sc, sr, empty, empty, tmp)


def test_segment_clearance_matches_brute_force():
    rng = np.random.default_rng(0)
    bl, bu = np.array([[0.0, 0.0], [5.0, -3.0]]), np.array([[2.0, 1.0], [6.0, -1.0]])
    sc, sr = np.array([[-3.0, 2.0]]), np.array([1.5])
    tmp = np.empty(2)
    ts = np.linspace(0, 1, 4001)[:, None]
    for _ in range(300):
        p = rng.uniform(-6, 8, 2)
        k = rng.normal(scale=3.0, size=2)
        pts = p + ts * k
        dbox = np.min([np.linalg.norm(np.clip(pts, bl[j], bu[j]) - pts, axis=1).min() for j in range(2)])
        inside = np.any([(np.all((pts >= bl[j]) & (pts <= bu[j]), axis=1)).any() for j in range(2)])
        dsph = (np.linalg.norm(pts - sc[0], axis=1) - sr[0]).min()
        clearance = min(0.0 if inside else dbox, dsph)
        r = 0.3
        if abs(clearance - r) < 1e-3:
            continue  # too close to call with 4001 samples
        assert K.segment_clear(p, k, r, sc, sr, bl, bu, tmp) == (clearance > r)


@pytest.mark.parametrize("dim", [2, 3])
def test_grid_neighbours_match_ckdtree(dim):
    rng = np.random.default_rng(dim)
    x = rng.uniform(0, 20, size=(500, dim))
    h = 2.5
    origin = np.zeros(dim)
    dims = np.full(dim, int(np.ceil(20 / h)), np.int64)
    start, items = K.build_grid(x, origin, h, dims)
    tree = cKDTree(x)
    buf = np.empty(len(x), np.int64)
    for p in rng.uniform(-1, 21, size=(50, dim)):
        cnt = K._near(p, x, origin, h, dims, start, items, h, buf)
        assert sorted(buf[:cnt]) == sorted(tree.query_ball_point(p, h))


def test_constriction_factor_is_clercs():
    assert PSOParams(constriction=True, c1=2.05, c2=2.05).chi == pytest.approx(0.729843788, abs=1e-9)
    assert PSOParams().chi == 1.0
    with pytest.raises(ValueError, match="c1 \\+ c2 > 4"):
        PSOParams(constriction=True)
