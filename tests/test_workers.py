"""Jobs in worker processes: results in the jobs' order, each reported as it ends, errors
raised, as many workers as the cores and the free memory allow."""

import pytest

from crowdmotion import workers


def square_after(job):  # module level: the workers import it by name
    import time

    value, wait_s = job
    time.sleep(wait_s)
    if value < 0:
        raise ValueError(f"negative: {value}")
    return value * value


def worker_setting(_):
    import os

    import numba

    return os.environ.get("CROWDMOTION_PRECOMPILE"), numba.get_num_threads()


def test_workers_share_the_cores_and_compile_in_themselves(monkeypatch):
    monkeypatch.setattr(workers, "cores", lambda: 4)
    import numba

    most = numba.config.NUMBA_NUM_THREADS
    assert workers.map_in_workers(worker_setting, [0, 1], 2) == [("0", min(2, most))] * 2


def test_results_come_back_in_the_jobs_order_each_reported_as_it_ends():
    seen = []
    jobs = [(1, 0.6), (2, 0.0), (3, 0.0)]  # the first ends last
    assert workers.map_in_workers(square_after, jobs, 2, lambda i, r: seen.append((i, r))) == [1, 4, 9]
    assert sorted(seen) == [(0, 1), (1, 4), (2, 9)] and seen[-1] == (0, 1)
    assert workers.map_in_workers(square_after, [], 4) == []


def test_an_error_in_a_job_is_raised_here():
    with pytest.raises(ValueError, match="negative: -2"):
        workers.map_in_workers(square_after, [(1, 0.0), (-2, 0.0)], 2)


def test_default_jobs_are_the_cores_unless_memory_holds_fewer(monkeypatch):
    monkeypatch.setattr(workers, "cores", lambda: 16)
    pages = {"SC_PAGE_SIZE": 4096, "SC_AVPHYS_PAGES": 64 * (1 << 30) // 4096}
    monkeypatch.setattr(workers.os, "sysconf", lambda name: pages[name])
    assert workers.default_jobs() == 16
    pages["SC_AVPHYS_PAGES"] = 2 * (1 << 30) // 4096  # 2 GiB free: three workers of 600 MB
    assert workers.default_jobs() == 3
    pages["SC_AVPHYS_PAGES"] = 100
    assert workers.default_jobs() == 1
    pages["SC_AVPHYS_PAGES"] = 64 * (1 << 30) // 4096
    # two jobs or more per worker, else none
    assert [workers.default_jobs(n) for n in (2, 3, 4, 21, 100)] == [1, 1, 2, 10, 16]
