"""The interactive RVO simulator as a user drives it: bad state set by hand is refused."""

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import rvo


def _sim():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20])), time_step=0.25, rng=np.random.default_rng(0))
    sim.add_agents([[2, 2], [2, 6], [2, 10]], [[18, 2], [18, 6], [18, 10]])
    return sim


@pytest.mark.parametrize("array,agent,value", [("positions", 0, np.nan), ("velocities", 1, np.inf),
                                               ("goals", 2, -np.inf)])
def test_a_nan_position_raises_value_error_on_step_naming_the_agent(array, agent, value):
    sim = _sim()
    getattr(sim, array)[agent] = value  # in this process: a numba kernel given it would crash Python
    before = sim.positions.copy()
    with pytest.raises(ValueError, match=rf"^{array} of agent {agent} is not finite: {value}$"):
        sim.step()
    assert sim.steps == 0 and np.array_equal(sim.positions, before, equal_nan=True), "nothing moved"


def test_an_agent_that_has_arrived_may_hold_nan_and_the_others_walk_on():
    sim = _sim()
    sim.active[0] = False
    sim.positions[0] = np.nan
    sim.step()
    assert sim.steps == 1 and np.isfinite(sim.positions[1:]).all()


def test_a_walker_from_rest_reaches_its_speed_at_the_comfortable_acceleration():
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [40, 10])), comfort_accel=0.8)
    sim.add_agents([[1, 5]], [[39, 5]], pref_speed=1.2)
    speeds = []
    for _ in range(8):
        sim.step()
        speeds.append(float(np.linalg.norm(sim.velocities[0])))
    assert np.allclose(speeds[:5], 0.8 * 0.25 * np.arange(1, 6))  # 0.2 m/s more each 0.25 s step
    assert speeds[-1] == pytest.approx(1.2)


def test_a_walker_passing_its_goal_at_speed_turns_in_instead_of_circling_it():
    # at 1.3 m/s, 1 m to the side of its goal: a 0.8 m/s² turn has a radius of 2.1 m, so
    # without slowing it would circle the goal for good
    sim = rvo.Simulator(cm.Scene(bounds=([0, 0], [20, 20])), comfort_accel=0.8)
    sim.add_agents([[10, 9]], [[10, 10]], pref_speed=1.3)
    sim.velocities[0] = [1.3, 0.0]
    while sim.time < 20 and sim.active.any():
        sim.step()
    assert sim.arrived.all() and sim.arrival_time[0] < 6.0, sim.arrival_time
