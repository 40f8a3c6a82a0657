"""Cars as rigid pairs and the formation's facing (issue 14, items 1 and 5; 003 Fig. 7)."""

import numpy as np
import pytest

from crowdmotion import Scene, formation, metrics
from crowdmotion.cli import builtin_scenarios
from crowdmotion.facing import MAX_TURN_RATE, turn_rate, wrap
from crowdmotion.groups import Group, Points
from crowdmotion.scenario import load_scenario, run_scenario
from crowdmotion.scene import Box, Circle

CAR_WIDTH = 1.8


def _car_angle(positions: np.ndarray) -> np.ndarray:
    """(T, cars) the way each car points: its pair's angle less 90 degrees."""
    axis = positions[:, 1::2] - positions[:, 0::2]
    return np.arctan2(axis[..., 1], axis[..., 0]) - np.pi / 2


@pytest.fixture(scope="module")
def traffic():
    path = next(p for p in builtin_scenarios() if p.stem == "formation_traffic")
    return run_scenario(load_scenario(path), progress=False)


def test_traffic_cars_stay_a_car_width_apart_in_every_frame(traffic):
    d = np.linalg.norm(traffic.trajectories.positions[:, 1::2] - traffic.trajectories.positions[:, 0::2], axis=2)
    assert np.abs(d / CAR_WIDTH - 1).max() < 0.05  # the bound; measured about 0.5 % (resampling)
    assert traffic.summary["formation"]["traffic"]["pair_width_error_max"] < 0.01  # the steps themselves


def test_traffic_cars_face_along_their_pair_and_turn_smoothly(traffic):
    traj = traffic.trajectories
    off = wrap(traj.facing[:, 0::2] - _car_angle(traj.positions))
    assert np.degrees(np.abs(off)).max() < 2.0  # resampled frames: pair and angle interpolated apart
    assert np.array_equal(traj.facing[:, 0::2], traj.facing[:, 1::2])  # both agents face the car's way
    assert turn_rate(traj.facing, traj.dt).max() <= MAX_TURN_RATE + 1e-6


def test_the_police_car_merges_into_the_middle_of_the_platoon_and_twists_it(traffic):
    traj = traffic.trajectories
    police = next(o for o in traffic.scenario.scene.obstacles if o.is_moving)
    t_merge = police.path.times[2]  # where the side road meets the lanes
    x = traj.positions[int(round(t_merge / traj.dt)), :, 0]
    px = police.path.positions[2][0]
    assert (x < px).sum() >= 4 and (x > px).sum() >= 4  # cars behind it and ahead of it
    assert traffic.summary["formation"]["traffic"]["car_heading_deviation_max_deg"] > 10  # a visible twist
    assert traffic.summary["agent_agent_overlaps"] == 0 and traffic.summary["agent_obstacle_penetrations"] == 0


def test_a_car_held_back_by_a_wall_stays_rigid():
    # two cars side by side; a wall just ahead of the right-hand wheel of the lower car
    scene = Scene(((0, -6), (40, 6)), [Box((8.0, -3.0), (9.0, -0.6))])
    groups = [Group("cars", 4, Points([[4.0, 0.0]]), (30.0, 0.0), radius=0.3, max_speed=3.0, pref_speed=2.0,
                    attributes={"formation": {"kind": "cars", "lanes": 1, "per_lane": 2, "car_gap": 6.0,
                                              "lane_width": 3.0}, "heading_deg": 0.0})]
    run = formation.run(scene, groups, {"max_steps": 600, "fps": None}, np.random.default_rng(0))
    traj = run.trajectories
    d = np.linalg.norm(traj.positions[:, 1::2] - traj.positions[:, 0::2], axis=2)
    assert np.abs(d / CAR_WIDTH - 1).max() < 0.01
    assert metrics.collision_audit(traj, scene).clean


def test_soldiers_face_their_formations_heading_standing_and_marching():
    scene = Scene(((0, -10), (40, 10)))
    groups = [Group("b", 9, Points([[5.0, -5.0]]), (5.0, 5.0), radius=0.25,
                    attributes={"formation": {"kind": "block", "rows": 3, "cols": 3}, "heading_deg": 90.0})]
    run = formation.run(scene, groups, {"max_steps": 400, "fps": None}, np.random.default_rng(0))
    yaw = run.trajectories.facing
    np.testing.assert_allclose(yaw[0], np.pi / 2)  # standing in rank before the first step
    np.testing.assert_allclose(yaw[-1], np.pi / 2, atol=1e-6)  # and in the target area at the end
    assert run.trajectories.metadata["facing"].startswith("formation")
