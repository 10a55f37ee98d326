"""A run's schedule: the jobs the clips not yet done need, each handed out once its input is ready."""

from __future__ import annotations

from concurrent.futures import FIRST_COMPLETED, wait
from pathlib import Path

from simgen.pipeline.executor import Executor
from simgen.pipeline.jobs import Job, Progress
from simgen.pipeline.run_state import clean_clip, motion_path, plan_path, read_plan, shard_marker


class Schedule:
    """What is left to do for the clips not yet done; hands out the next jobs as results come."""

    def __init__(
        self, root: Path, payload: dict, clip_indices: list[int], shard_frames: int, min_shards: int, progress: Progress
    ):
        self.root, self.payload, self.progress = root, payload, progress
        self.shard_frames, self.min_shards = shard_frames, min_shards
        self.plans: dict[int, dict] = {}
        self.left: dict[int, set[int]] = {}  # clip -> first frames of its shards not yet done
        self.records: list[dict] = []
        self.clip_indices = clip_indices

    def first_jobs(self) -> list[Job]:
        return [job for i in self.clip_indices for job in self._resume_or_capture(i)]

    def _job(self, kind: str, clip_index: int, frames: tuple[int, int] = (0, 0)) -> Job:
        return Job(kind, self.payload, clip_index, str(self.root), self.shard_frames, self.min_shards, frames)

    def _resume_or_capture(self, clip_index: int) -> list[Job]:
        if plan_path(self.root, clip_index).exists() and motion_path(self.root, clip_index).exists():
            return self._planned(clip_index, read_plan(self.root, clip_index))
        return [self._job("capture", clip_index)]

    def _planned(self, clip_index: int, plan: dict) -> list[Job]:
        self.plans[clip_index] = plan
        shards = [tuple(r) for r in plan["shards"]]
        left = {first for first, _ in shards if not shard_marker(self.root, clip_index, first).exists()}
        self.left[clip_index] = left
        self.progress("start", clip_index, plan["frames"])
        done = sum(stop - first for first, stop in shards if first not in left)
        if done:
            self.progress("frame", clip_index, done)
        if not left and len(shards) > 1:
            return [self._job("assemble", clip_index)]
        return [self._job("shard", clip_index, r) for r in shards if r[0] in left]

    def finished(self, job: Job, result: dict) -> list[Job]:
        """The jobs that `job`'s result makes possible."""
        if job.kind == "capture":
            return self._planned(job.clip_index, result)
        if job.kind == "shard" and len(self.plans[job.clip_index]["shards"]) > 1:
            self.left[job.clip_index].discard(job.frames[0])
            return [self._job("assemble", job.clip_index)] if not self.left[job.clip_index] else []
        self.records.append(result)  # a whole-clip shard, or an assembled clip
        clean_clip(self.root, job.clip_index)
        self.progress("done", job.clip_index, self.plans[job.clip_index]["frames"])
        return []


def run_jobs(schedule: Schedule, executor: Executor) -> list[dict]:
    """Run the schedule's jobs on `executor` as their inputs become ready; returns the clips' records."""
    pending = {executor.submit(job): job for job in schedule.first_jobs()}
    while pending:
        finished, _ = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
        executor.drain()
        for future in finished:
            job = pending.pop(future)
            for follow in schedule.finished(job, future.result()):
                pending[executor.submit(follow)] = follow
    executor.drain()
    return schedule.records
