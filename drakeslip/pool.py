"""Many independent jobs (cases, solves, shards): in this process, or in spawned worker processes."""
from __future__ import annotations

import os


def results_of(fn, tasks, jobs: int = 1, initializer=None, initargs=()):
    """Yield ``(tag, fn(*args))`` for each ``(tag, args)`` of ``tasks``: in order in this process when ``jobs``
    is 1 or less, else as each finishes in ``jobs`` spawned processes. ``initializer(*initargs)`` runs first in
    each worker, never in this process (the caller sets up its own). Spawned, not forked: a child forked from a
    process whose torch or numba threads are running can deadlock. Workers run one BLAS/OpenMP thread each."""
    if jobs <= 1:
        for tag, args in tasks:
            yield tag, fn(*args)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")  # inherited by the workers: one process per core, no thread spinning
    with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn"), initializer=initializer,
                             initargs=initargs) as pool:
        futures = {pool.submit(fn, *args): tag for tag, args in tasks}
        for future in as_completed(futures):
            yield futures[future], future.result()
