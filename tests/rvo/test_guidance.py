"""Guidance (rvo.guidance): where along the distance field an agent aims."""

import pytest

from crowdmotion.rvo.guidance import field_window


@pytest.mark.parametrize("cell, cells", [(0.15, 3), (0.2, 2), (0.25, 2), (0.5, 2), (2.0, 2)])
def test_the_aim_reaches_about_as_far_on_fine_cells_as_on_a_persons_and_two_cells_at_least(cell, cells):
    # two cells of 0.15 m (bodies of radius 0.15 m) reach only 0.3 m: the aim swung with
    # each cell's rounding; the window is sized in metres, never under two cells
    assert field_window(cell) == cells
