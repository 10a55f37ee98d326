"""Where jobs run, as a run sees it: one interface, `Executor`, for the local pool (`local_pool`) and
Ray (`ray_cluster`), and the function their workers run."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass

from simgen.pipeline.jobs import Job, Progress, run_job


@dataclass(frozen=True)
class Executor:
    """An open executor. cpus: jobs it runs at once (automatic shards split the clips that many ways);
    submit: start a job (its result, a `ClipRecord` or plan dict, comes in the future); drain: hand the
    progress events its workers reported so far to the run's `Progress`."""

    cpus: int
    submit: Callable[[Job], Future]
    drain: Callable[[], None]


def run_job_reporting(job: Job, queue) -> dict:
    """A job in a worker process or a Ray task: its progress events go to `queue`, for `forward`."""
    return run_job(job, lambda *event: queue.put(event))


def forward(queue, progress: Progress) -> None:
    """Hand the events workers put on `queue` to `progress`."""
    while not queue.empty():
        progress(*queue.get())
