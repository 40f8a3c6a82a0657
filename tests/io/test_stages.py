"""The stage of each agent per frame (routes) goes through every trajectory file."""

import numpy as np
import pytest

from crowdmotion.scenario import parse_scenario, run_scenario
from crowdmotion.trajectories import Trajectories
from tests.test_journeys import FOUNTAIN


@pytest.fixture(scope="module")
def routed():
    return run_scenario(parse_scenario(FOUNTAIN), progress=False).trajectories


@pytest.mark.parametrize("suffix", [".parquet", ".csv", ".sqlite"])
def test_a_routes_stage_per_frame_round_trips(tmp_path, routed, suffix):
    back = Trajectories.load(routed.save(tmp_path / f"run{suffix}"))
    assert back.stage is not None and back.stage.dtype == np.int16
    assert np.array_equal(back.stage, routed.stage)
    assert (routed.stage[~routed.active_mask] == -1).all() and set(np.unique(routed.stage)) == {-1, 0, 1, 2}
    assert back.metadata["stages"] == routed.metadata["stages"]


def test_pedpy_still_reads_a_file_with_stages(tmp_path, routed):
    pedpy = pytest.importorskip("pedpy")
    path = routed.save(tmp_path / "run.sqlite")
    data = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=path)
    assert len(data.data) == int(routed.active_mask.sum())


def test_runs_without_routes_write_no_stage_column(tmp_path):
    plain = Trajectories(np.zeros((2, 1, 2)), 1.0)
    import pyarrow.parquet as pq

    assert "stage" not in pq.read_table(plain.save(tmp_path / "plain.parquet")).column_names
    assert Trajectories.load(tmp_path / "plain.parquet").stage is None
    assert Trajectories.load(plain.save(tmp_path / "plain.sqlite")).stage is None


@pytest.mark.parametrize("kind", ["b-spline", "linear"])
def test_a_routes_stage_survives_resampling_for_a_dcc(routed, kind):
    from crowdmotion.scene import scene_of
    from crowdmotion.smoothing import resample_checked

    at24 = resample_checked(routed, 24.0, kind, scene_of(routed), max_speed=np.zeros(routed.n_agents))
    assert at24.stage is not None and at24.stage.shape == at24.positions.shape[:2]
    assert set(np.unique(at24.stage)) == {-1, 0, 1, 2}
    # each frame in the stage its agent was in at the run's frame it ends in
    k = np.minimum(np.ceil(np.arange(at24.n_frames) / 24.0 / routed.dt - 1e-9).astype(int), routed.n_frames - 1)
    present = at24.active_mask
    assert np.array_equal(at24.stage[present], routed.stage[k][present])
