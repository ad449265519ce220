"""The process a local cluster's workers are forked from: one fork server that has imported what
a campaign worker needs, started early.

A spawned worker process imports Dask, numpy, pandas and satfmu's campaign task on its own (1-2 s
of CPU each before its first sample). A local cluster's workers are instead forked from
multiprocessing's fork server (Dask's ``forkserver`` method), which imports
:data:`WORKER_PRELOAD` once; :func:`start` launches it in the background, so that its imports
overlap the driver's own (``satfmu campaign`` starts it before it reads the scenario). The fork
server is single-threaded: forking it is safe, unlike forking the driver, whose Dask client runs
an event loop thread. This module imports neither Dask nor numpy.
"""
from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import os

WORKER_ENV = {"MALLOC_ARENA_MAX": "1", "MALLOC_TRIM_THRESHOLD_": str(64 * 2**20),
              "MALLOC_MMAP_THRESHOLD_": str(32 * 2**20)}
"""glibc malloc settings of a local cluster's workers. A worker runs its tasks in a thread of its
own, whose allocations go to a thread arena that glibc trims eagerly, and Dask sets
``MALLOC_TRIM_THRESHOLD_=65536`` (memory back to the system sooner), which also freezes malloc's
adaptive mmap threshold: a campaign worker, which allocates and frees the same arrays of 10-400
KiB every sample, then maps, unmaps and trims them every sample. One arena and high thresholds
keep its heap at its working size. Measured on mrp_200deg samples (CPU per sample, one process,
500 samples): 2.08 ms in the main thread, 2.54 ms in another thread, 2.03 ms in another thread
with these settings."""
ONE_BLAS_THREAD = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
"""One BLAS/OpenMP thread per worker (what Dask's ``distributed.nanny.pre-spawn-environ`` sets)."""
WORKER_PRELOAD = ("distributed", "numpy", "pandas", "pyarrow", "satfmu.sims.campaign.engine",
                  "satfmu.sims.campaign.scenario_task")
"""What the fork server imports before it forks the workers: every worker starts with them."""


def start() -> None:
    """Launch the fork server (importing :data:`WORKER_PRELOAD`, its environment this process's
    with :data:`WORKER_ENV` and :data:`ONE_BLAS_THREAD`) unless it runs; returns at once.

    malloc reads its settings when a process starts: a worker forked from the server has the
    server's, so they are given to the server. This process's environment is restored.
    """
    multiprocessing.get_context("forkserver").set_forkserver_preload(list(WORKER_PRELOAD))
    env = {**ONE_BLAS_THREAD, **WORKER_ENV}
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
