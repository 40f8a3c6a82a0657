"""Formations that follow a route round walls (issue 13): the mesh walks down the exact
distance field where walls hide the goal, turns to its direction of travel, and recovers."""

import numpy as np

import crowdmotion as cm
from crowdmotion import formation
from crowdmotion.metrics import collision_audit
from crowdmotion.trajectories import Trajectories


def _walk(scene, template, goal, start, heading=None, limit=3000):
    sim = formation.Simulator(scene, time_step=0.1)
    kw = {} if heading is None else {"heading": heading}
    sim.add_group(template, goal=goal, start=start, radius=0.3, **kw)
    frames = [sim.positions.copy()]
    while not sim.done and sim.steps < limit:
        sim.step()
        frames.append(sim.positions.copy())
    return sim, Trajectories(np.array(frames), sim.dt, radius=0.3)


def test_a_column_follows_a_u_shaped_corridor_round_two_corners_and_recovers():
    # east 26 m, north 16 m, back west: the goal lies straight north of the start, behind a wall
    scene = cm.Scene(bounds=([0, 0], [40, 40]), obstacles=[cm.Box([0, 4], [26, 16]), cm.Box([30, 0], [40, 40]),
                                                           cm.Box([0, 20], [30, 40])])
    sim, traj = _walk(scene, formation.block(10, 2, spacing=1.0), cm.Rect([1, 16.5], [10, 19.5]), (7, 2), 0.0)
    g = sim.groups[0]
    assert g.recovered_at is not None, "the column never recovered in the target area"
    assert collision_audit(traj, scene).clean
    assert abs(np.cos(g.heading) + 1) < 0.05, "it faces west, the way it arrived, not its start heading"
    assert g.edge_error[-1] < 0.02


def test_a_block_goes_room_to_room_through_a_door_narrower_than_itself_and_recovers():
    # a 6 m wide block, a 3 m door off the straight line between start and goal
    scene = cm.Scene(bounds=([0, 0], [41, 20]), obstacles=[cm.Box([20, 5], [21, 20]), cm.Box([20, 0], [21, 2])])
    sim, traj = _walk(scene, formation.block(5, 5, spacing=1.2), cm.Rect([29, 12], [37, 18]), (8, 14))
    g = sim.groups[0]
    assert g.recovered_at is not None
    assert collision_audit(traj, scene).clean
    assert (traj.positions[-1, :, 0] > 21).all(), "all 25 came through the 3 m door"
    assert max(g.edge_error) > 0.05, "the door squeezed the mesh (edge lengths off by over 5 %) on the way"


def test_without_walls_between_the_formation_walks_straight_as_before():
    scene = cm.Scene(bounds=([0, -15], [60, 15]), obstacles=[cm.Circle([30, 12], 1.0)])  # off the line
    sim, traj = _walk(scene, formation.block(3, 3, spacing=1.2), (50, 0), (8, 0))
    assert sim.groups[0].recovered_at is not None
    assert np.abs(traj.positions[..., 1]).max() < 2.5, "no detour when the goal is in sight"


def test_a_block_walking_down_a_corridor_to_its_corner_faces_the_way_it_walks():
    # the goal lies round the corner; the field's cells lead diagonally into the near wall
    # first, so a short look down them turned the block 25° off the way it slid along it.
    # Pulled taut, the rest shape is about 10° off (the wall's field holds the block off
    # the taut line), and its soldiers, facing the group's travel, about 2°
    scene = cm.Scene(bounds=([0, 0], [40, 40]), obstacles=[cm.Box([0, 0], [30, 20]), cm.Box([0, 28], [22, 40])])
    sim = formation.Simulator(scene, time_step=0.1)
    sim.add_group(formation.block(4, 4, spacing=1.2), goal=(26.0, 36.0), start=(5.0, 24.0), radius=0.3)
    centres, headings, facing = [sim.positions.mean(axis=0)], [sim.groups[0].heading], [np.median(sim.facing())]
    while sim.positions[:, 0].mean() < 18.0 and sim.steps < 400:
        sim.step()
        centres.append(sim.positions.mean(axis=0))
        headings.append(sim.groups[0].heading)
        facing.append(np.median(sim.facing()))
    travel = np.diff(np.array(centres), axis=0)
    way = np.arctan2(travel[:, 1], travel[:, 0])
    off = lambda a: np.degrees(np.median(np.abs(np.angle(np.exp(1j * (np.array(a[1:]) - way))))[20:]))  # noqa: E731
    assert sim.positions[:, 0].mean() >= 18.0
    assert off(headings) < 12.0  # the rest shape, turned where the route leads
    assert off(facing) < 0.5 * off(headings)  # the soldiers, along the group's travel


def _corner_scene():
    # an L street: 10 m wide going east, then 10 m wide going north; the goal round the corner
    return cm.Scene(bounds=([0, -5], [30, 30]), obstacles=[cm.Box([0, 5], [20, 30])])


def test_a_block_with_no_heading_sets_out_along_its_street_and_ends_facing_the_way_it_came_in():
    # the straight line to the goal (48 degrees) runs through the wall: the block used to start
    # as a diamond facing it, walk the street so, and re-form at 48 degrees on the goal
    sim, traj = _walk(_corner_scene(), formation.block(3, 6, spacing=1.2), (25, 22), (5, 0))
    g = sim.groups[0]
    assert abs(np.degrees(g.heading0)) < 8, np.degrees(g.heading0)  # east, down its street
    assert g.recovered_at is not None and collision_audit(traj, _corner_scene()).clean
    final = np.degrees(np.angle(np.exp(1j * sim.facing()).mean()))
    assert abs(final - 90) < 8, final  # north, the way its last leg came in
    rest = traj.positions[0] - traj.positions[0].mean(axis=0)
    end = traj.positions[-1] - traj.positions[-1].mean(axis=0)
    turn = np.degrees(g.heading0 + np.arctan2(np.sum(rest[:, 0] * end[:, 1] - rest[:, 1] * end[:, 0]),
                                              np.sum(rest * end)))
    assert abs(turn - final) < 1 and sim.groups[0].heading_given is False, turn  # square to it, not a diamond


def test_the_report_judges_a_formation_turned_off_its_heading_as_out_of_shape():
    from crowdmotion.formation.simulation import orientation

    sim = formation.Simulator(cm.Scene(bounds=([0, -10], [40, 10])), time_step=0.1)
    sim.add_group(formation.block(4, 4, spacing=1.2), goal=(30, 0), start=(8, 0), radius=0.3)
    g = sim.groups[0]
    square = orientation(sim, g, sim.slot_positions(0))
    assert square["orientation_error_deg"] < 1e-6 and square["oriented_rms_m"] < 1e-9
    c, s = np.cos(np.radians(40)), np.sin(np.radians(40))
    rest = g.mesh.rest - g.mesh.rest.mean(axis=0)
    diamond = orientation(sim, g, rest @ np.array([[c, -s], [s, c]]).T + (30, 0))  # in shape, turned 40 degrees
    assert abs(diamond["orientation_error_deg"] - 40) < 1e-6 and diamond["oriented_rms_m"] > 1.0
    assert diamond["heading_deg"] == 0.0
