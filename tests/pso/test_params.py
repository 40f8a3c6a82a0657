"""crowdmotion.pso.params: the method's parameters and what they let a swarm do."""

import warnings

import numpy as np
import pytest

import crowdmotion as cm
from crowdmotion import pso


def test_a_clamp_that_lets_particles_outrun_their_max_speed_is_warned_of_from_python_too():
    # a robotics user's drones (max_speed 3) flew at 3.45 m/s with the default v_max
    # (0.5 m an axis every 0.25 s: 3.46 m/s in 3D), and pso.simulate said nothing
    scene = cm.Scene(bounds=([0, 0, 0], [30, 30, 15]))
    group = cm.Group("drones", 3, spawn=cm.Rect([1, 1, 1], [5, 29, 4]), goal=cm.Rect([25, 2, 3], [29, 28, 12]),
                     radius=0.3, max_speed=3.0)
    with pytest.warns(UserWarning, match=r"up to 3\.46 m/s, above the group's max_speed 3 m/s"):
        pso.simulate(scene, [group], pso.PSOParams(iterations=2), np.random.default_rng(0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # within it: nothing to say
        pso.simulate(scene, [group], pso.PSOParams(iterations=2, v_max=[0.4, 0.4, 0.4]), np.random.default_rng(0))
