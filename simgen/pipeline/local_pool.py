"""The local executor: jobs in this process (1 worker) or a pool of fresh processes (spawned: one engine each)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager
from multiprocessing import get_context

from simgen.pipeline.executor import Executor, forward, run_job_reporting
from simgen.pipeline.jobs import Job, Progress, run_job


@contextmanager
def local_pool(workers: int, progress: Progress) -> Iterator[Executor]:
    """Open `workers` local workers (1: this process); the pool is shut down on leaving."""
    if workers == 1:

        def inline(job: Job) -> Future:
            future = Future()
            future.set_result(run_job(job, progress))
            return future

        yield Executor(1, inline, lambda: None)
        return
    # One BLAS thread per worker: the workers already fill the cores.
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")
    context = get_context("spawn")
    with context.Manager() as manager:
        queue = manager.Queue()
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            yield Executor(
                workers, lambda job: pool.submit(run_job_reporting, job, queue), lambda: forward(queue, progress)
            )
