"""benchmarks/mdp_clusters.py: the clusters of Algorithm 3's threaded step, counted by hand."""

import runpy
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "mdp_clusters.py"


def test_agents_within_two_cells_share_a_thread_and_the_busiest_part_is_measured():
    cluster_loads = runpy.run_path(str(SCRIPT), run_name="clusters")["cluster_loads"]
    cells = np.array([[0, 0], [1, 1], [3, 3], [10, 10]])  # the first three linked (2 apart at most)
    largest, busiest = cluster_loads(cells, np.array([4.0, 3.0, 2.0, 1.0]), 2)
    assert largest == 3
    assert busiest == 1.5  # three turns on the first thread, one on the second: 3 over a mean of 2
    largest, busiest = cluster_loads(cells + np.array([[0, 0], [0, 0], [5, 5], [0, 0]]), np.ones(4), 2)
    assert largest == 2 and busiest == 1.0  # (0, 0)-(1, 1) on one thread, (8, 8)-(10, 10) on the other
