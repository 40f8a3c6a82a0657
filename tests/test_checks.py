"""Refusals shared by every method (crowdmotion.checks): how much room a spawn region has."""

import re

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion.checks import _room_at_least, check_spawn_capacity, spawn_room
from crowdmotion.groups import Disc, Group, Rect
from crowdmotion.placement import spawn_positions

GAP = 0.05  # the methods' default spawn_gap


def _drones(spawn: Rect, count: int = 50) -> Group:
    return Group("drones", count, spawn=spawn, goal=Rect([-5, -5, 20], [5, 5, 30]), radius=0.3)


@pytest.mark.parametrize("top", [0.3, 0.4], ids=["flat", "0.1 m thick"])
def test_a_launch_pad_thinner_than_a_body_is_judged_by_its_area_and_takes_its_fifty_drones(top):
    # a 20 x 10 m pad in a 3D scene was judged by its volume: "room for about 34" drones
    # of radius 0.3 m, where one layer side by side holds hundreds (and a flat one had
    # "no free room" at all)
    scene = cm.Scene(bounds=([-30, -30, 0], [30, 30, 50]), obstacles=[cm.Box([-2, 8, 0], [2, 12, 35])])
    group = _drones(Rect([-10, 15, 0.3], [10, 25, top]))
    room, free = spawn_room(scene, group, GAP)
    assert room >= 500 and free == pytest.approx(200 * (top - 0.3) if top > 0.3 else 200, rel=0.02)
    check_spawn_capacity(scene, 0, group, GAP)  # not refused
    starts = spawn_positions(scene, group, np.empty((0, 3)), np.empty(0), GAP, np.random.default_rng(1))
    assert starts.shape == (50, 3) and np.all((starts[:, 2] >= 0.3) & (starts[:, 2] <= top))
    d = np.linalg.norm(starts[:, None] - starts[None], axis=-1) + np.eye(50) * 9
    assert d.min() >= 0.6 + GAP


def test_a_pad_that_cannot_hold_the_count_is_refused_naming_its_area():
    scene = cm.Scene(bounds=([-30, -30, 0], [30, 30, 50]))
    with pytest.raises(ValueError, match=r"has room for at most \d+ agents of radius 0.3 m \(200 m² free"):
        check_spawn_capacity(scene, 0, _drones(Rect([-10, 15, 0.3], [10, 25, 0.3]), 5000), GAP)


def _most_placed(scene: cm.Scene, group: Group, room: int, seed: int) -> int:
    """How many of room + 1 bodies the placement puts in the spawn region."""
    g = Group("g", room + 1, spawn=group.spawn, goal=group.goal, radius=group.radius)
    try:
        return len(spawn_positions(scene, g, np.empty((0, scene.dim)), np.empty(0), GAP, np.random.default_rng(seed)))
    except ValueError as exc:
        found = re.search(r"placed (\d+)", str(exc))
        return int(found.group(1)) if found else 0


def test_the_spawn_room_never_refuses_what_the_placement_places():
    # the room is a packing bound: slabs, strips, flat regions, discs, obstacles, in 2D and 3D
    rng = np.random.default_rng(1)
    for trial in range(24):
        dim = 2 + trial % 2
        ball = cm.Circle if dim == 2 else cm.Sphere
        obstacles = [ball(rng.uniform(0, 8, dim), rng.uniform(0.2, 1.0)) for _ in range(rng.integers(0, 4))]
        scene = cm.Scene(bounds=([0] * dim, [8] * dim), obstacles=obstacles)
        a, size = rng.uniform(0, 5, dim), rng.uniform(0.5, 3, dim)
        if trial % 3 == 0:
            size[rng.integers(0, dim)] = rng.choice([0.0, 0.05, 0.3])
        spawn = Disc(a + 1.5, 1.5) if trial % 7 == 0 else Rect(a, a + size)
        group = Group("g", 1, spawn=spawn, goal=Rect([0] * dim, [1] * dim), radius=float(rng.uniform(0.15, 0.4)))
        room, _ = spawn_room(scene, group, GAP)
        assert _most_placed(scene, group, room, trial) <= room, trial
        assert _room_at_least(scene, group, GAP) <= room, trial
