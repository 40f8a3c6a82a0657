"""Every method package exposes ``simulate(scene, groups, params, rng)`` as a function,
whatever else has been imported (a submodule of the same name would shadow it)."""

import importlib

import pytest

from crowdmotion.registry import available, get_method


@pytest.mark.parametrize("name", ["mdp", "pso", "rvo", "formation"])
def test_simulate_is_the_function_even_after_the_adapter_loaded(name):
    get_method(name)  # imports the adapter and, through it, the method's modules
    package = importlib.import_module(f"crowdmotion.{name}")
    assert callable(package.simulate) and package.simulate.__name__ == "simulate"


def test_every_method_is_registered():
    assert available() == ["formation", "mdp", "pso", "rvo"]
