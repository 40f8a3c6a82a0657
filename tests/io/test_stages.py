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
