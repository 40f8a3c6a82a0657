"""Independent jobs side by side in worker processes, one per core: the demo's scenes and
``verify``'s cases.

Workers are spawned (never forked: the parent may hold numba's threads), one per core by
default and as many as the free memory holds at ``WORKER_MEMORY`` each. Each worker's
numba gets the cores divided by the workers, and the compile-on-every-core start-up of
:mod:`crowdmotion._precompile` is off in workers: the workers themselves spread the
compiling over the cores, and that start-up in each of many workers would fork a child
per core from each (on 64 cores, hundreds of processes compiling the same kernels). A
job's result does not depend on the worker that ran it: each job seeds its own run.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Callable, Sequence

from crowdmotion._precompile import cores

WORKER_MEMORY = 600 << 20  # bytes a worker may take (the largest built-ins peak near 480 MB)


def default_jobs(n_jobs: int | None = None) -> int:
    """Workers by default: one per core, no more than the free memory holds, and for
    ``n_jobs`` jobs no more than half as many (each worker gets two jobs or more); one,
    no workers, where that leaves fewer than two. A worker compiles its first method's
    kernels on one core, where one process would spread them over every core: with too
    few jobs to fill the others meanwhile, workers lose (three scenes of three methods
    on an empty cache, 2 cores: 20.9 s on two workers, 14.6 s in one process)."""
    if n_jobs is not None and n_jobs // 2 < 2:
        return 1
    try:
        free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows) or no such name
        free = cores() * WORKER_MEMORY
    most = min(cores(), free // WORKER_MEMORY, n_jobs // 2 if n_jobs is not None else cores())
    return max(1, most)


def _worker_start(threads: int) -> None:
    """A worker's set-up: its share of the cores for numba; a cold run compiles in the
    worker itself (see the module's notes)."""
    import numba

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    os.environ["CROWDMOTION_PRECOMPILE"] = "0"


def map_in_workers(fn: Callable, items: Sequence, jobs: int, on_done: Callable | None = None) -> list:
    """``fn(item)`` for every item in ``jobs`` worker processes (``fn`` a module-level
    function, items picklable), started in the items' order; returns the results in that
    order. ``on_done(index, result)`` runs here as each job finishes. An exception in a
    job is raised here once the running jobs end; Ctrl-C cancels the jobs not started."""
    jobs = max(1, min(jobs, len(items)))
    results: list = [None] * len(items)
    if not items:
        return results
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(jobs, mp_context=context, initializer=_worker_start,
                             initargs=(max(1, cores() // jobs),)) as pool:
        index = {pool.submit(fn, item): i for i, item in enumerate(items)}
        pending = set(index)
        try:
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in sorted(finished, key=index.get):
                    results[index[future]] = future.result()
                    if on_done is not None:
                        on_done(index[future], results[index[future]])
        except BaseException:
            for future in pending:
                future.cancel()
            raise
    return results
