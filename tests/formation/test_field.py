"""The obstacle potential field, eq. (2), and its update for moving obstacles."""

import numpy as np
import pytest

from crowdmotion.formation.field import PotentialField, disc_field
from crowdmotion.scene import Box, Circle, Scene, Sphere


def test_field_values_follow_eq_2_away_from_the_centre():
    scene = Scene(((0, 0), (20, 20)), [Circle((10, 10), 2.0)])
    field = PotentialField(scene, reach=3.0, cell=0.1)
    pts = np.array([[13.05, 10.05], [10.05, 14.45], [16.05, 10.05], [10.05, 10.05], [3.0, 3.0]])
    vec, f = field.sample(pts)
    centres = np.floor(pts / 0.1) * 0.1 + 0.05  # the field is read at the cell centre
    d = np.linalg.norm(centres - 10.0, axis=1) - 2.0
    want = np.where(d <= 0, 1.0, np.clip(1 - d / 3.0, 0, 1))
    assert f == pytest.approx(want)
    unit = (centres - 10.0) / np.linalg.norm(centres - 10.0, axis=1, keepdims=True)
    assert vec[:3] == pytest.approx(want[:3, None] * unit[:3])
    assert f[4] == 0.0 and np.all(vec[4] == 0)


def test_a_box_pushes_away_from_its_core():
    # the core is the box shrunk by the field's range on every side: a small box's centre
    # (the paper's choice), a long wall's middle line, so beside it the push is square to it
    scene = Scene(((0, 0), (30, 10)), [Box((10, 4), (20, 6))])
    vec, f = PotentialField(scene, reach=2.0, cell=0.05).sample(np.array([[16.025, 7.025], [21.525, 5.525]]))
    assert f[0] == pytest.approx(1 - (7.025 - 6) / 2)
    assert vec[0] / np.linalg.norm(vec[0]) == pytest.approx([0.0, 1.0])  # beside the wall: its normal
    assert vec[1] / np.linalg.norm(vec[1]) == pytest.approx(np.array([3.525, 0.525]) / np.hypot(3.525, 0.525))
    small = Scene(((0, 0), (30, 10)), [Box((10, 4), (13, 6))])  # no more than 2r across: its centre
    vec, _ = PotentialField(small, reach=2.0, cell=0.05).sample(np.array([[14.025, 7.025]]))
    assert vec[0] / np.linalg.norm(vec[0]) == pytest.approx(np.array([2.525, 2.025]) / np.hypot(2.525, 2.025))


def test_a_corridor_of_two_large_boxes_pushes_across_it_not_back_along_it():
    # RiMEA 6's corner (2 m corridor, left turn at the inner corner (10, 2)): in the corner
    # square the push away from the big boxes' centres pointed back down the first leg
    scene = Scene(((0, 0), (22, 22)), [Box((0, 2), (10, 12)), Box((12, 0), (22, 12))])
    vec, _ = PotentialField(scene, reach=2.0, cell=0.25).sample(np.array([[11.1, 4.1], [5.1, 1.1]]))
    assert abs(vec[0, 1]) < 1e-9 and abs(vec[1, 0]) < 1e-9


def test_the_bounds_push_square_into_the_scene_as_a_long_wall_does():
    # RiMEA 6's first leg has the bounds (y = 0) for its outer wall: without their push the
    # upper wall's field alone pressed a column's files against them
    scene = Scene(((0, 0), (22, 22)), [Box((0, 2), (10, 12)), Box((12, 0), (22, 12))])
    vec, f = PotentialField(scene, reach=2.0, cell=0.25).sample(np.array([[5.1, 0.6], [5.1, 1.4], [0.1, 21.9]]))
    assert f[0] == pytest.approx(1 - 0.625 / 2) and vec[0] == pytest.approx([0.0, (1 - 0.625 / 2) - (1 - 1.375 / 2)])
    assert vec[1, 1] == pytest.approx(-vec[0, 1])  # the corridor's middle line is the field's balance
    assert vec[2] == pytest.approx([1 - 0.125 / 2, -(1 - 0.125 / 2)])  # a corner: both sides
    _, f = PotentialField(scene, reach=2.0, cell=0.25, bounds=False).sample(np.array([[5.1, 0.6]]))
    assert f[0] == pytest.approx(1 - 1.375 / 2)  # the upper wall's alone


def test_moving_obstacle_repaints_only_the_cells_it_touches():
    mover = Circle((5, 5), 1.0, path=([0.0, 10.0], [(5, 5), (45, 5)]))
    scene = Scene(((0, 0), (50, 10)), [Circle((40, 8), 1.0), mover])
    field = PotentialField(scene, reach=1.5, cell=0.25)
    for t in (0.0, 3.0, 7.5):
        field.update(t)
        fresh = PotentialField(Scene(scene.bounds, [Circle(mover.path.at(t), 1.0)]), reach=1.5, cell=0.25,
                               bounds=False)
        assert np.array_equal(field.dynamic_f, fresh.static_f)
        assert np.allclose(field.dynamic_vec, fresh.static_vec)
    # each update clears and paints two small windows, far fewer than the grid's cells
    assert field.cells_updated < 3 * 2 * (2 * 2.5 / 0.25 + 2) ** 2
    assert field.cells_updated < field.static_f.size


def test_groups_as_discs_and_3d_scenes():
    vec, f = disc_field(np.array([[0.0, 3.0]]), np.array([[0.0, 0.0]]), np.array([2.0]), 2.0)
    assert f[0] == pytest.approx(0.5) and vec[0] == pytest.approx([0.0, 0.5])
    with pytest.raises(ValueError, match="2D scenes"):
        PotentialField(Scene(((0, 0, 0), (5, 5, 5)), [Sphere((1, 1, 1), 0.5)]), 1.0, 0.5)
