"""Guidance (rvo.guidance): where along the distance field an agent aims."""

import pytest

from crowdmotion.rvo.guidance import field_window


@pytest.mark.parametrize("cell, cells", [(0.15, 3), (0.2, 2), (0.25, 2), (0.5, 2), (2.0, 2)])
def test_the_aim_reaches_about_as_far_on_fine_cells_as_on_a_persons_and_two_cells_at_least(cell, cells):
    # two cells of 0.15 m (bodies of radius 0.15 m) reach only 0.3 m: the aim swung with
    # each cell's rounding; the window is sized in metres, never under two cells
    assert field_window(cell) == cells


@pytest.mark.parametrize("seed", [2, 4])
def test_a_walker_at_the_mouth_of_a_door_just_wider_than_a_body_aims_through_it(seed):
    # SteerSuite's doorway-one-way, the corridor closed at its ends: two walkers of radius
    # 0.5 m bound through a 1.2 m door (0.5 m cells: no cell centre in it a body stands on).
    # Aiming at cell centres only, the second one found none of the door's cells in sight,
    # aimed at its own cell's centre a few centimetres off and paced there for good.
    import numpy as np

    import crowdmotion as cm
    from crowdmotion import rvo

    scene = cm.Scene(bounds=([-20, -1], [20, 3.1]), obstacles=[
        cm.Box([-20, 3.1], [20, 5]), cm.Box([-20, -3], [20, -1]), cm.Box([-0.2, -3], [0, -0.1]),
        cm.Box([-0.2, 1.1], [0, 5])])
    sim = rvo.Simulator(scene, rng=np.random.default_rng(seed))
    sim.add_agents([[-10, 2], [-10, 0]], [15, 1], radius=0.5, max_speed=1.5, pref_speed=1.3)
    while sim.time < 60 and not sim.arrived.all():
        sim.step()
    assert sim.arrived.all(), f"still before the door: {sim.positions[~sim.arrived]}"
    assert sim.time < 30
