"""Recording a live simulation: the Trajectories a game that steps the crowd itself exports."""

import warnings

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import rvo
from crowdmotion.metrics import collision_audit


def _live_run():
    """Six walkers cross a room; two more come in at 5 s, one leaves at 8 s, a player is
    driven through, and a door stands in the middle until 6 s."""
    scene = cm.Scene(bounds=([0, 0], [20, 10]))
    sim = rvo.Simulator(scene, rng=np.random.default_rng(2))
    ys = np.linspace(2, 8, 3)
    sim.add_agents(np.c_[np.full(3, 2.0), ys], np.c_[np.full(3, 18.0), ys], radius=0.3)
    sim.add_agents(np.c_[np.full(3, 18.0), ys + 0.5], np.c_[np.full(3, 2.0), ys + 0.5], radius=0.3)
    player = sim.add_agents([[12, 0.5]], [[12, 0.5]], radius=0.3)
    sim.drive(player, [0.0, 0.8])
    door = sim.add_obstacle(cm.Box([9.8, 4.2], [10.2, 5.0]))
    rec = rvo.Recorder(sim)
    for k in range(1, 81):
        sim.step()
        if k == 20:
            sim.add_agents([[2, 0.6], [18, 9.4]], [[18, 0.6], [2, 9.4]], radius=0.3)
        if k == 24:
            sim.remove_obstacle(door)
        if k == 32:
            sim.remove_agents([0])
        rec.record()
    return sim, rec


def test_a_recorded_live_run_holds_every_agent_in_the_frames_it_was_in_and_is_clean():
    sim, rec = _live_run()
    traj = rec.trajectories(smoothing="none")
    assert traj.positions.shape == (81, 9, 2) and traj.dt == sim.dt
    act = traj.active_mask
    assert not act[:20, 7:].any() and act[20:60, 7:].all(), "the two added at step 20 are there from then on"
    assert act[:32, 0].all() and not act[32:, 0].any(), "the one removed at step 32 is gone from then on"
    assert np.allclose(traj.positions[:20, 7], traj.positions[20, 7]), "drawn where it first stood before it came"
    assert np.allclose(traj.positions[-1][act[-1]], sim.positions[act[-1]])
    assert list(np.unique(traj.group)) == ["agents 0", "agents 1", "agents 2", "agents 3"]
    scene = cm.Scene.from_dict(traj.metadata["scene"])  # the door with the time it stood
    report = collision_audit(traj, scene)
    assert report.agent_obstacle == 0 and all(6 in (e.a, e.b) for e in report.events), report


def test_the_recorded_steps_are_relaxed_for_characters_by_default_and_stay_clean():
    sim, rec = _live_run()
    raw, relaxed = rec.trajectories(smoothing="none"), rec.trajectories()
    assert relaxed.metadata["relaxed"]["window_s"] == 1.0
    walkers = np.arange(6)
    jerk = lambda t: np.abs(np.diff(t.positions[:, walkers], 3, axis=0)).mean()  # noqa: E731
    assert jerk(relaxed) < jerk(raw)
    scene = cm.Scene.from_dict(relaxed.metadata["scene"])
    report = collision_audit(relaxed, scene)
    assert report.agent_obstacle == 0 and all(6 in (e.a, e.b) for e in report.events), report


def test_a_frame_missed_or_taken_twice_is_refused():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [10, 10])))
    sim.add_agents([[1, 1]], [[9, 9]])
    rec = rvo.Recorder(sim)
    with pytest.raises(ValueError, match="record once after every step"):
        rec.record()
    sim.step()
    sim.step()
    with pytest.raises(ValueError, match="simulator is at step 2 and the last frame was taken at step 0"):
        rec.record()
    with pytest.raises(ValueError, match="smoothing must be 'relaxed' or 'none'"):
        rec.trajectories(smoothing="soft")


def _teleport(dt=1 / 60):
    """One agent driven east at 1 m/s for 1 s, then placed across a wall, then driven on."""
    scene = cm.Scene(bounds=([0, 0], [30, 20]), obstacles=[cm.Box([12, 6], [15, 14])])
    sim = rvo.Simulator(scene, time_step=dt)
    p = sim.add_agents([[2, 10]], [[2, 10]], radius=0.3)
    sim.drive(p, [1.0, 0.0])
    rec = rvo.Recorder(sim)
    steps = int(round(1.0 / dt))
    for _ in range(steps):
        sim.step()
        rec.record()
    sim.place(p, [25, 10])
    for _ in range(steps):
        sim.step()
        rec.record()
    return scene, rec, steps


@pytest.mark.parametrize("smoothing", ["none", "relaxed"])
def test_an_agent_placed_across_a_wall_jumps_it_is_not_audited_as_walking_through(tmp_path, smoothing):
    scene, rec, steps = _teleport()
    traj = rec.trajectories(smoothing=smoothing)
    assert traj.metadata["jumps"] == [[pytest.approx(1.0), 0]]
    x = traj.positions[:, 0, 0]
    assert x[steps] == pytest.approx(3.0) and x[steps + 1] == pytest.approx(25.0 + 1 / 60), "the jump stays a jump"
    report = collision_audit(traj, scene)
    assert report.agent_obstacle == 0 and report.agent_agent == 0, report
    from crowdmotion.metrics import path_length

    assert path_length(traj)[0] == pytest.approx(2.0, abs=0.02), "walked 2 m; the 22 m jump is not walked"
    back = cm.Trajectories.load(traj.save(tmp_path / "t.parquet"))
    assert back.metadata["jumps"] == traj.metadata["jumps"] and collision_audit(back, scene).agent_obstacle == 0


@pytest.mark.parametrize("kind", ["linear", "catmull-rom", "b-spline"])
def test_a_jump_resampled_to_24_fps_stays_a_jump(kind):
    from crowdmotion.trajectories import resample

    scene, rec, steps = _teleport(dt=0.25)  # 4 steps a second: new frames fall inside the jump's step
    out = resample(rec.trajectories(smoothing="none"), 24.0, kind)
    x = out.positions[:, 0, 0]
    before, after = x[out.times < 1.25 - 1e-9], x[out.times >= 1.25 - 1e-9]
    assert before.max() <= 3.0 + 1e-9 and after.min() >= 25.0, "nothing in between the two places"
    assert np.allclose(before[out.times[:len(before)] >= 1.0], 3.0), "it holds its place until the step ends"
    assert out.metadata["jumps"] == [[pytest.approx(out.times[len(before) - 1]), 0]]
    assert collision_audit(out, scene).agent_obstacle == 0


def test_a_game_s_crowd_stepped_at_60_fps_keeps_its_relaxed_paths_and_their_speed_limits():
    # 200 walkers bound for the room's corners, stepped at 60 steps a second, 20 more added
    # at 5 s: a step kept straight used to jump back to the relaxed path within one frame,
    # outrun the speed limit by the paths' gap times 60, flag the next step, and so on
    # until every step of every path was straight (a warning said 100 %)
    scene = cm.Scene(bounds=([0, 0], [30, 30]), obstacles=[cm.Box([8, 8], [12, 12]), cm.Box([18, 17], [22, 21])])
    corners = [cm.Rect([1, 1], [5, 5]), cm.Rect([25, 1], [29, 5]), cm.Rect([1, 25], [5, 29]), cm.Rect([25, 25], [29, 29])]
    grid = np.array([[x, y] for x in np.arange(1.0, 29.1, 1.3) for y in np.arange(1.0, 29.1, 1.3)])
    free = grid[~np.any([np.all((grid > np.array(b.lower) - 0.6) & (grid < np.array(b.upper) + 0.6), axis=1)
                         for b in scene.obstacles], axis=0)]
    rng = np.random.default_rng(0)
    starts = free[rng.choice(len(free), 200, replace=False)]
    sim = rvo.Simulator(scene, time_step=1 / 60, remove_on_arrival=False, rng=np.random.default_rng(1))
    sim.add_goal_regions(corners)
    for k, corner in enumerate(corners):
        sim.add_agents(starts[k::4], corner.center, goal_region=corner)
    rec = rvo.Recorder(sim)
    for step in range(320):
        if step == 300:  # 20 more, where nobody stands now
            near = np.linalg.norm(free[:, None] - sim.positions[sim.present][None], axis=2).min(axis=1)
            sim.add_agents(free[near > 0.9][:20], corners[0].center, goal_region=corners[0])
        sim.step()
        rec.record()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "kept the plan's straight moves on ..." warning
        traj = rec.trajectories()
    relaxed = traj.metadata["relaxed"]
    assert relaxed["straight_segments"] < 0.01 * relaxed["segments"]
    rep = collision_audit(traj, scene)
    assert rep.agent_agent == 0 and rep.agent_obstacle == 0
    speed = np.linalg.norm(np.diff(traj.positions, axis=0), axis=-1) / traj.dt
    assert (speed <= sim.params["max_speed"][None] + 1e-9)[traj.active_mask[:-1] & traj.active_mask[1:]].all()
