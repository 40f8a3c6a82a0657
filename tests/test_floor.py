"""The walkable floor (crowdmotion.floor): the walkable area of a disc round a point,
checked against shapely's exact geometry."""

import numpy as np
import pytest
import shapely

from crowdmotion import Box, Circle, Polygon, Scene
from crowdmotion.floor import DiscFloor, WalkableFloor, disc_kernel

# a 4 m corridor ending in a 1 m door with a pillar and a triangle in it; the bounds
# are not a whole number of 0.2 m cells long
OBSTACLES = [Box([0, 0], [30, 3]), Box([0, 7], [30, 10]), Box([29.6, 0], [30.3, 4.5]), Box([29.6, 5.5], [30.3, 10]),
             Circle([10, 5], 0.7), Polygon([[15, 4], [17, 4.3], [16, 6]])]
BOUNDS = ([0.0, 0.0], [33.05, 10.0])


def _shape(ob):
    if isinstance(ob, Box):
        return shapely.box(*ob.lower, *ob.upper)
    if isinstance(ob, Circle):
        return shapely.Point(ob.center).buffer(ob.radius, quad_segs=256)
    return ob.geometry


def test_a_discs_walkable_area_matches_shapelys_disc_minus_obstacles_within_the_bounds():
    walkable = shapely.box(*BOUNDS[0], *BOUNDS[1]).difference(shapely.union_all([_shape(o) for o in OBSTACLES]))
    floor = DiscFloor(Scene(bounds=BOUNDS, obstacles=OBSTACLES), 2.0)
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(0.3, 32.75, 3000), rng.uniform(0.3, 9.7, 3000)]
    pts = pts[shapely.contains_xy(walkable, pts[:, 0], pts[:, 1])][:200]
    exact = np.array([walkable.intersection(shapely.Point(p).buffer(2.0, quad_segs=256)).area for p in pts])
    got = floor.at(pts)
    assert exact.min() < 0.6 * np.pi * 4  # some discs are well cut by walls
    assert np.abs(got - exact).max() < 0.03 * exact.max()
    assert np.sqrt(np.mean(((got - exact) / exact) ** 2)) < 0.01


def test_a_disc_reads_its_full_area_in_the_open_and_half_on_a_long_wall():
    floor = DiscFloor(Scene(bounds=([0, 0], [20, 20])), 2.0)
    assert floor.at(np.array([[10.0, 10.0], [10.3, 9.9]])) == pytest.approx(np.pi * 4, rel=1e-6)
    assert floor.at(np.array([[10.0, 0.0]]))[0] == pytest.approx(np.pi * 2, rel=0.03)
    assert floor.at(np.array([[-5.0, 10.0]]))[0] == 0.0  # beyond the bounds


def test_a_cells_cover_is_its_walkable_share_inside_the_bounds():
    floor = WalkableFloor(Scene(bounds=([0, 0], [1.1, 1.0]), obstacles=[Box([0, 0], [0.5, 1.0])]))
    # cells of 0.2 m: the box's edge at x = 0.5 halves the third column (its centre, on the edge, counts as
    # blocked); the last column is half past the bounds
    assert floor.cover[:, 0] == pytest.approx([0, 0, 0.5, 1, 1, 0.5])
    assert floor.blocked[:, 0].tolist() == [True, True, True, False, False, False]


def test_the_disc_kernel_covers_the_discs_area():
    assert disc_kernel(2.0, 0.2).sum() * 0.04 == pytest.approx(np.pi * 4, rel=0.002)
