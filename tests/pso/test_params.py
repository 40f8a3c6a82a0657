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


def test_one_v_max_number_applies_to_every_axis_and_is_still_checked():
    # docs/pso.md: "one value applies to every axis"; v_max = 0.5 was refused as "Input should be a valid list"
    from crowdmotion.pso.params import make_params

    assert make_params(v_max=0.5).axis_vmax(3) == [0.5, 0.5, 0.5]
    assert make_params(v_max=[0.5]).axis_vmax(2) == [0.5, 0.5]
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match=r"pso.v_max: must be a finite number more than 0"):
            make_params(v_max=bad)
    for bad in ("0.5", True, [], [0.5] * 4):
        with pytest.raises(ValueError, match=r"pso.v_max: must be a number for every axis or a list of 1 to 3"):
            make_params(v_max=bad)
    with pytest.raises(ValueError, match=r"pso.v_max.0: must be more than 0"):
        make_params(v_max=[-1.0])
