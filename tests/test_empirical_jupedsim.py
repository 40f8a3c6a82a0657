"""JuPedSim's Collision-Free Speed Model on the empirical suite's bottleneck
(benchmarks/empirical_jupedsim.py): a slow check that the comparison runs end to end."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("jupedsim")

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "empirical_jupedsim.py"


def _load():
    spec = importlib.util.spec_from_file_location("empirical_jupedsim", _PATH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_csm_empties_the_one_metre_bottleneck_at_a_positive_flow():
    ej = _load()
    from crowdmotion.empirical import stationary
    from crowdmotion.verify import crossing_times

    setup = ej._bottleneck_setups()[1.0]
    max_time = 400.0
    traj = ej.run_jupedsim("csm", setup.scene, setup.groups, seed=0, max_time_s=max_time)
    assert traj.n_agents == 200 and traj.dt == pytest.approx(0.25)
    assert traj.metadata["error"] is None and not traj.metadata["frozen"]
    assert traj.metadata["all_left"] and not traj.active_mask[-1].any()
    assert traj.metadata["end_time"] <= max_time
    flow = stationary(crossing_times(traj, 0, 12.0))[2]
    assert np.isfinite(flow) and flow > 0
