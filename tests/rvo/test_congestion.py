"""Congestion-aware guidance: the field re-solved with density-weighted costs."""

import numpy as np

import crowdmotion as cm
from crowdmotion.groups import Rect
from crowdmotion.rvo.congestion import CongestionRouter
from crowdmotion.routing import distance_fields


def _fields():
    scene = cm.Scene(bounds=([0, 0], [20, 10]), obstacles=[cm.Box([8, 2], [10, 10]), cm.Circle([15, 4], 1.5)])
    return distance_fields(scene, [Rect([18, 8], [19.5, 9.5])], 0.3, 0.25)


def test_with_nobody_about_the_re_solved_field_is_the_exact_one():
    f = _fields()
    d = CongestionRouter(f, 1.0).resolve(np.array([[-50.0, -50.0]]), f.dist)
    finite = np.isfinite(f.dist)
    assert np.array_equal(np.isfinite(d), finite)
    np.testing.assert_allclose(d[finite], f.dist[finite], atol=1e-9)


def test_a_crowd_makes_its_side_of_a_corridor_dearer():
    scene = cm.Scene(bounds=([0, 0], [30, 4]))
    f = distance_fields(scene, [Rect([29, 0.5], [29.8, 3.5])], 0.25, 0.25)
    crowd = np.stack(np.meshgrid(np.linspace(10, 20, 25), np.linspace(0.5, 1.5, 4)), -1).reshape(-1, 2)
    d = CongestionRouter(f, 1.0).resolve(crowd, f.dist)[0]
    row = int(5 / 0.25)  # x = 5 m, before the crowd
    low, high = d[row, int(1.0 / 0.25)], d[row, int(3.0 / 0.25)]
    assert f.dist[0, row, 4] == f.dist[0, row, 12], "the exact field does not care"
    assert low > high, "the way past the crowd's side costs more"


def test_congestion_zero_keeps_the_exact_field():
    f = _fields()
    router = CongestionRouter(f, 0.0)
    assert not router.enabled
    assert router.resolve(np.array([[5.0, 5.0]]), f.dist) is f.dist
