"""Recording a live simulation: the Trajectories a game that steps the crowd itself exports."""

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
