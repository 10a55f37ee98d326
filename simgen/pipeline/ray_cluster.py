"""The Ray executor: jobs as Ray tasks on a cluster (`ray start --head` on one machine or many); a task
whose worker dies is retried (a retried shard rewrites its files from its first frame)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

from simgen.errors import UserError
from simgen.pipeline.executor import Executor, forward, run_job_reporting
from simgen.pipeline.jobs import Progress
from simgen.pipeline.memory import ARROW_ENVIRONMENT


@contextmanager
def ray_cluster(address: str | None, progress: Progress) -> Iterator[Executor]:
    """Connect to the cluster at `address` (None: start a local one), shut down on leaving."""
    import ray
    from ray.util.queue import Queue

    try:
        environment = {name: os.environ.get(name, value) for name, value in ARROW_ENVIRONMENT.items()}
        ray.init(address=address, logging_level="ERROR", log_to_driver=False, runtime_env={"env_vars": environment})
    except (ConnectionError, ValueError) as error:
        raise UserError(f"cannot reach the Ray cluster at {address!r}: {error}") from None
    try:
        queue = Queue()
        task = ray.remote(max_retries=3)(run_job_reporting)
        cpus = int(ray.cluster_resources().get("CPU", 1))
        yield Executor(cpus, lambda job: task.remote(job, queue).future(), lambda: forward(queue, progress))
    finally:
        ray.shutdown()
