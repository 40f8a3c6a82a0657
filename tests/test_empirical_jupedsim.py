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


def test_groups_sharing_a_spawn_region_start_apart_so_jupedsim_takes_them():
    import dataclasses

    ej = _load()
    setup = ej.empirical._bot("rvo")["BOT b 0.9"]
    east = setup.groups[0]
    halves = [dataclasses.replace(east, name=f"east {k}", count=50, attributes={**east.attributes, "route": None})
              for k in range(2)]  # two groups in one holding area
    traj = ej.run_jupedsim("csm", setup.scene, halves, seed=0, max_time_s=0.5)
    assert traj.metadata["error"] is None and traj.n_agents == 100
    start = traj.positions[0]
    d = np.linalg.norm(start[:, None] - start[None], axis=2) + np.eye(len(start)) * 9
    assert d.min() >= 2 * 0.2


def test_the_counterflow_walkers_in_jupedsim_take_the_side_exit_nearer_where_they_walk():
    ej = _load()
    setup = ej.empirical._bot("rvo")["BOT b 0.9"]
    traj = ej.run_jupedsim("csm", setup.scene, setup.groups, seed=0, max_time_s=40.0)
    assert traj.metadata["error"] is None and traj.n_agents == 200
    gone = ~traj.active_mask[-1]
    last = traj.positions[-1]
    # those that left did so through a side exit, on both sides
    assert gone.sum() > 20
    assert np.all((last[gone, 1] < -2.0) | (last[gone, 1] > 5.6))
    assert (last[gone, 1] < -2.0).any() and (last[gone, 1] > 5.6).any()
    same, corr = ej.empirical.bot_exit_sides(traj)
    assert same > 0.7, same
