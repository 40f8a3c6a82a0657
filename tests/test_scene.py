"""Scene distances, measured all obstacles at once, against each obstacle on its own."""

import numpy as np
import pytest

import crowdmotion.scene as scene_module
from crowdmotion.obstacle_primitives import ObstacleSet
from crowdmotion.scene import Box, Circle, Polygon, Scene, Sphere


def _one_by_one(scene, p, t=None):
    d = np.full(p.shape[:-1], np.inf)
    for ob in scene.obstacles:
        if t is None and ob.is_moving:
            continue
        d = np.minimum(d, ob.signed_distance(p - (ob.offset(t) if t is not None else 0.0)))
    return d


@pytest.mark.parametrize("block", [1 << 18, 7])  # 7: a few points per block, many blocks
def test_static_distance_equals_each_obstacle_measured_alone(monkeypatch, block):
    monkeypatch.setattr(scene_module, "SHAPES_AT_ONCE", block)
    rng = np.random.default_rng(3)
    obstacles = [Box(lo, lo + rng.uniform(0.5, 3, 2)) for lo in rng.uniform(0, 17, (12, 2))]
    obstacles += [Circle(c, r) for c, r in zip(rng.uniform(0, 20, (5, 2)), rng.uniform(0.2, 2, 5))]
    obstacles += [Polygon([[2.0, 2.0], [5.0, 2.5], [3.0, 6.0]]),
                  Circle([10.0, 10.0], 1.0, path=([0.0, 5.0], [[10.0, 10.0], [15.0, 12.0]]))]
    scene = Scene([[0.0, 0.0], [20.0, 20.0]], obstacles)
    p = rng.uniform(-1, 21, (3, 50, 2))
    np.testing.assert_array_equal(scene.static_obstacle_distance(p), _one_by_one(scene, p))
    np.testing.assert_array_equal(scene.obstacle_distance(p, 2.5), _one_by_one(scene, p, 2.5))
    scene.obstacles.append(Box([0.0, 0.0], [20.0, 1.0]))  # a changed list is measured as it is now
    np.testing.assert_array_equal(scene.static_obstacle_distance(p), _one_by_one(scene, p))
    assert Scene([[0.0, 0.0], [1.0, 1.0]]).static_obstacle_distance(p).min() == np.inf


def test_static_distance_in_3d():
    rng = np.random.default_rng(4)
    scene = Scene([[0.0] * 3, [10.0] * 3], [Box([1.0, 1.0, 1.0], [3.0, 2.0, 5.0]), Sphere([6.0, 6.0, 6.0], 1.5),
                                             Box([5.0, 0.0, 0.0], [6.0, 4.0, 2.0])])
    p = rng.uniform(0, 10, (200, 3))
    np.testing.assert_array_equal(scene.static_obstacle_distance(p), _one_by_one(scene, p))


def test_obstacle_set_places_moving_obstacles_anew_and_keeps_the_rest():
    path = ([0.0, 4.0], [[5.0, 5.0], [9.0, 5.0]])
    scene = Scene([[0.0, 0.0], [20.0, 10.0]],
                  [Box([1.0, 1.0], [2.0, 3.0]), Circle([5.0, 5.0], 0.5, path=path), Circle([15.0, 2.0], 1.0),
                   Box([4.0, 4.0], [6.0, 6.0], path=path), Polygon([[10.0, 6.0], [12.0, 6.0], [11.0, 8.0]])])
    reused = ObstacleSet(scene)
    for t in (0.0, 1.0, 2.5, 4.0, 6.0):
        got, fresh = reused.at(t, 0.1), ObstacleSet(scene).at(t, 0.1)
        for name in ("circ_c", "circ_r", "circ_v", "seg_a", "seg_b", "seg_v"):
            np.testing.assert_array_equal(getattr(got, name), getattr(fresh, name))
        assert got.circ_c[0, 0] == pytest.approx(5.0 + t) if t <= 4 else got.circ_c[0, 0] == 9.0
        assert np.allclose(got.circ_v[0], [1.0, 0.0] if t < 4 else [0.0, 0.0])


def test_clearance_is_the_room_to_the_nearest_wall_or_static_obstacle():
    scene = Scene(bounds=([0, 0], [10, 10]), obstacles=[Circle([5, 5], 1.0)])
    got = scene.clearance([[1.0, 5.0], [5.0, 7.5], [9.5, 9.0]])
    np.testing.assert_allclose(got, [1.0, 1.5, 0.5])
