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
