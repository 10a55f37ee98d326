"""`simgen generate`: clips -> datasets, on this machine's cores or on a Ray cluster, resumable.

A clip is made in three kinds of work unit, each a plain-data job that runs in this process, a
spawned worker process or a Ray task:

1. capture: the engine plays the clip's match (it must play in order, so once per clip) and its
   motion is stored in the run state (`.simgen/motion/NNNN/`, arrays that shards memory-map), with
   the clip's shard plan (`NNNN.json`, written last): frame ranges of at most `shard_frames` frames.
2. shard: a frame range rendered, labelled and streamed to disk frame by frame (memory stays flat
   whatever the clip's length). A clip of one shard is written straight to its final files;
   otherwise KITTI and OpenPCDet shards write their per-frame files in place and the other formats
   a partial Parquet clip in the run state. A shard is recorded done by `.simgen/shards/NNNN/AAAAAA.json`.
3. assemble: a clip of several shards streams the partial clips, in frame order, into its final
   files (or just gathers the per-frame files' records), then is recorded done (`.simgen/clips/NNNN.json`).

Every frame depends only on (scenario, seed, clip index, frame index), so executors, worker
counts and shard sizes give byte-identical datasets, and `--resume` skips what is recorded done
(clips, captures, shards). The manifest is written once, when every clip is done. A lock file
stops a second run from writing into the same directory.
"""

from __future__ import annotations

import ctypes
import fcntl
import gc
import json
import math
import os
import shutil
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Callable

from simgen.atomic import atomic_path, check_output_allowed
from simgen.datasets.formats import dataset_format  # names only: imports no writer
from simgen.errors import UserError
from simgen.scenario import Scenario

WORK_DIR = ".simgen"  # run state inside the output directory; removed when the dataset is finished
CARD_NAME = "README.md"  # simgen.datasets.write.CARD_NAME (not imported: workers import this module light)
#: Events: "capture" (motion frames to capture), "captured" (more captured), "start" (frames of the
#: clip), "frame" (more rendered), "done" (frames of the finished clip); with the clip index.
Progress = Callable[[str, int, int], None]
AUTO_SHARD_MAX_FRAMES = 3000  # automatic shards: at most 5 minutes of 10 Hz frames lost to a kill
CAPTURE_REPORT_FRAMES = 50  # motion frames captured between progress reports
#: Arrow's pool: jemalloc where pyarrow has it (its Linux wheels), else the C heap. The default
#: (mimalloc in pyarrow 26) keeps what it frees for reuse and the C heap fragments while shards are
#: read back; a 6,000-frame clip's join in a fresh process peaks at 447 (mimalloc), 429 (C heap) and
#: 403 MiB (jemalloc). Arrow reads the variable when pyarrow is imported: `simgen generate` sets it
#: before, for itself, its workers and its Ray tasks.
ARROW_ENVIRONMENT = {"ARROW_DEFAULT_MEMORY_POOL": "jemalloc" if sys.platform.startswith("linux") else "system"}
_MALLOC_TRIM = getattr(ctypes.CDLL(None), "malloc_trim", None)  # glibc's; None elsewhere


@dataclass(frozen=True)
class Job:
    """One unit of work (plain data: it crosses process and Ray boundaries).

    kind: "capture", "shard" or "assemble"; frames: the shard's range (first, stop)."""

    kind: str
    scenario: dict  # Scenario.model_dump(mode="json")
    clip_index: int
    root: str
    shard_frames: int = 0  # capture: frames per shard, 0 for automatic
    min_shards: int = 1  # capture: automatic shards split a clip at least this many ways
    frames: tuple[int, int] = (0, 0)


def _state(root: Path, *parts: str) -> Path:
    return root / WORK_DIR / Path(*parts)


def motion_path(root: Path, clip_index: int) -> Path:
    return _state(root, "motion", f"{clip_index:04d}")


def plan_path(root: Path, clip_index: int) -> Path:
    return _state(root, "motion", f"{clip_index:04d}.json")


def shard_marker(root: Path, clip_index: int, first: int) -> Path:
    return _state(root, "shards", f"{clip_index:04d}", f"{first:06d}.json")


def shard_root(root: Path, clip_index: int, first: int) -> Path:
    """Where a shard writes its partial Parquet clip."""
    return _state(root, "shards", f"{clip_index:04d}", f"{first:06d}")


def clip_marker(root: Path, clip_index: int) -> Path:
    return _state(root, "clips", f"{clip_index:04d}.json")


def _write_json(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, sort_keys=True))


def shard_ranges(frames: int, shard_frames: int, min_shards: int) -> list[tuple[int, int]]:
    """Frame ranges [first, stop) of a clip: `shard_frames` each (0: automatic, at least
    `min_shards` shards and at most AUTO_SHARD_MAX_FRAMES frames each)."""
    if shard_frames <= 0:
        shard_frames = min(math.ceil(frames / max(min_shards, 1)), AUTO_SHARD_MAX_FRAMES)
    return [(first, min(first + shard_frames, frames)) for first in range(0, frames, shard_frames)]


def writes_in_place(format: str, shards: int) -> bool:
    """Whether a clip's shards write their frames' final files themselves (else partial Parquet clips)."""
    return shards == 1 or dataset_format(format).frame_files


def run_capture(job: Job, progress: Progress) -> dict:
    """Capture the clip's motion into the run state; returns its plan {"frames", "shards"}."""
    from simgen.motion.clip_io import write_clip_arrays
    from simgen.motion.engine import capture_motion
    from simgen.pipeline.clip import engine_seed, frame_count

    scenario = Scenario.model_validate(job.scenario)
    root = Path(job.root)
    unreported = [0]  # motion frames captured since the last report

    def tick(number: int) -> None:
        unreported[0] += number
        if unreported[0] >= CAPTURE_REPORT_FRAMES:
            progress("captured", job.clip_index, unreported[0])
            unreported[0] = 0

    progress("capture", job.clip_index, scenario.motion.frames)
    clip = capture_motion(scenario.motion, engine_seed(scenario, job.clip_index), tick)
    progress("captured", job.clip_index, unreported[0])
    frames = frame_count(scenario, clip)
    write_clip_arrays(clip, motion_path(root, job.clip_index))
    plan = {"frames": frames, "shards": shard_ranges(frames, job.shard_frames, job.min_shards)}
    _write_json(plan_path(root, job.clip_index), plan)
    return plan


def run_shard(job: Job, progress: Progress) -> dict:
    """Render and write one shard of a clip, frame by frame; returns its `ClipRecord` as a dict
    (the clip's own when the shard is the whole clip)."""
    from simgen.datasets.write import ClipWriter
    from simgen.motion.clip_io import read_clip_arrays
    from simgen.pipeline.clip import clip_name, render_frames
    from simgen.scan.sensor_rig import sensor_infos

    scenario = Scenario.model_validate(job.scenario)
    root = Path(job.root)
    first, stop = job.frames
    plan = json.loads(plan_path(root, job.clip_index).read_text())
    whole = len(plan["shards"]) == 1
    fmt = scenario.dataset.format
    if writes_in_place(fmt, len(plan["shards"])):
        target, target_format = root, fmt
    else:
        target, target_format = shard_root(root, job.clip_index, first), "parquet"
        target.mkdir(parents=True, exist_ok=True)
    clip = read_clip_arrays(motion_path(root, job.clip_index))
    with ClipWriter(target, target_format, clip_name(job.clip_index), job.clip_index, sensor_infos(scenario), first) as writer:
        for frame in render_frames(scenario, clip, job.clip_index, first, stop):
            writer.add(frame)
            progress("frame", job.clip_index, 1)
        record = writer.close().to_dict()
    _write_json(clip_marker(root, job.clip_index) if whole else shard_marker(root, job.clip_index, first), record)
    return record


def run_assemble(job: Job, progress: Progress) -> dict:
    """Join a clip's shards: stream the partial clips into the final files in frame order (or, for
    formats whose shards wrote in place, gather their records); returns the clip's `ClipRecord`."""
    from simgen.datasets.parquet import labelled_frames
    from simgen.datasets.records import ClipRecord
    from simgen.datasets.write import ClipWriter
    from simgen.labels.statistics import LabelStatistics
    from simgen.pipeline.clip import clip_name
    from simgen.scan.sensor_rig import sensor_infos

    scenario = Scenario.model_validate(job.scenario)
    root = Path(job.root)
    plan = json.loads(plan_path(root, job.clip_index).read_text())
    shards = [ClipRecord.from_dict(json.loads(shard_marker(root, job.clip_index, first).read_text())) for first, _ in plan["shards"]]
    fmt, name = scenario.dataset.format, clip_name(job.clip_index)
    if writes_in_place(fmt, len(shards)):
        labels = LabelStatistics.empty()
        for shard in shards:
            labels = labels.merged(LabelStatistics.from_dict(shard.labels))
        record = ClipRecord(
            fmt, name, job.clip_index, sum(s.frames for s in shards), sum(s.points for s in shards), sum(s.boxes for s in shards),
            shards[0].start_s, tuple(sorted((f for s in shards for f in s.files), key=lambda f: f.path)), labels.to_dict(),
        )
    else:
        with ClipWriter(root, fmt, name, job.clip_index, sensor_infos(scenario)) as writer:
            for first, _ in plan["shards"]:
                for frame in labelled_frames(shard_root(root, job.clip_index, first), name):
                    writer.add(frame)
            record = writer.close()
    _write_json(clip_marker(root, job.clip_index), record.to_dict())
    return record.to_dict()


RUNNERS = {"capture": run_capture, "shard": run_shard, "assemble": run_assemble}


def run_job(job: Job, progress: Progress | None = None) -> dict:
    try:
        return RUNNERS[job.kind](job, progress or (lambda *_: None))
    finally:
        release_memory()


def release_memory() -> None:
    """Hand what the last job freed back to the OS (Arrow's pool, the C heap), so that a process's
    peak is its largest job's rather than that job plus what earlier ones left in the allocators
    (a clip's capture, then its shards, then their assembly)."""
    import pyarrow

    gc.collect()
    pyarrow.default_memory_pool().release_unused()
    if _MALLOC_TRIM is not None:
        _MALLOC_TRIM(0)


class OutputLock:
    """An exclusive lock on an output directory, held for the whole run (released if we die)."""

    def __init__(self, root: Path):
        (root / WORK_DIR).mkdir(parents=True, exist_ok=True)
        self._file = open(root / WORK_DIR / "lock", "a+")
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.seek(0)
            holder = self._file.read().strip() or "another process"
            self._file.close()
            raise UserError(f"{root}: another simgen generate is writing here ({holder}); wait for it or use another -o") from None
        self._file.seek(0)
        self._file.truncate()
        self._file.write(f"pid {os.getpid()} on {os.uname().nodename}")
        self._file.flush()

    def release(self) -> None:
        fcntl.flock(self._file, fcntl.LOCK_UN)
        self._file.close()


def prepare_output(root: Path, scenario: Scenario, resume: bool, overwrite: bool) -> bool:
    """Check the output directory against --resume/--overwrite; record the scenario for resumes.

    True: a resumed run whose manifest is already written (only the card or the cleanup is left)."""
    state = root / WORK_DIR / "scenario.json"
    resolved = json.dumps(scenario.model_dump(mode="json"), sort_keys=True)
    complete = (root / "manifest.json").exists()
    interrupted = state.exists()
    occupied = complete or interrupted or any(child.name != WORK_DIR for child in root.iterdir())
    if overwrite and occupied:
        if not (complete or interrupted):
            raise UserError(f"{root}: not a simgen dataset; refusing to delete it with --overwrite")
        for child in root.iterdir():
            if child.name != WORK_DIR:
                shutil.rmtree(child) if child.is_dir() else child.unlink()
        for kind in ("clips", "motion", "shards"):
            shutil.rmtree(root / WORK_DIR / kind, ignore_errors=True)
    elif resume and occupied:
        if complete and not interrupted and (root / CARD_NAME).exists():
            raise UserError(f"{root}: the dataset is already complete (manifest.json); nothing to resume")
        if not (complete or interrupted):
            raise UserError(f"{root}: holds files but no interrupted simgen generate run to resume")
        if interrupted and state.read_text() != resolved:
            raise UserError(f"{root}: was started with another scenario or options; resume with the same ones, or --overwrite")
        for leftover in root.rglob("*.tmp-*"):  # files an interrupted writer never renamed
            leftover.unlink()
        if complete:
            return True
    elif occupied and not overwrite:
        raise UserError(f"{root}: already exists; use --resume to finish an interrupted run or --overwrite to replace it")
    (root / WORK_DIR / "clips").mkdir(parents=True, exist_ok=True)
    with atomic_path(state) as tmp:
        tmp.write_text(resolved)
    return False


def done_clips(root: Path) -> dict[int, dict]:
    """Clips recorded as finished by an earlier (interrupted) run."""
    records = {}
    for marker in sorted(_state(root, "clips").glob("*.json")):
        record = json.loads(marker.read_text())
        records[record["clip_index"]] = record
    return records


class _Clips:
    """What is left to do for the clips not yet done; hands out the next jobs as results come."""

    def __init__(self, root: Path, payload: dict, clip_indices: list[int], shard_frames: int, min_shards: int, progress: Progress):
        self.root, self.payload, self.progress = root, payload, progress
        self.shard_frames, self.min_shards = shard_frames, min_shards
        self.automatic_shards = shard_frames <= 0
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
            return self._planned(clip_index, json.loads(plan_path(self.root, clip_index).read_text()))
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
        self._clean(job.clip_index)
        self.progress("done", job.clip_index, self.plans[job.clip_index]["frames"])
        return []

    def _clean(self, clip_index: int) -> None:
        """The run state of a done clip: its motion and shards are no longer needed."""
        shutil.rmtree(_state(self.root, "shards", f"{clip_index:04d}"), ignore_errors=True)
        shutil.rmtree(motion_path(self.root, clip_index), ignore_errors=True)
        plan_path(self.root, clip_index).unlink(missing_ok=True)


def _schedule(clips: _Clips, submit: Callable[[Job], Future], drain: Callable[[], None]) -> list[dict]:
    """Run the clips' jobs as their inputs become ready; returns the clips' records."""
    pending = {submit(job): job for job in clips.first_jobs()}
    while pending:
        finished, _ = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
        drain()
        for future in finished:
            job = pending.pop(future)
            for follow in clips.finished(job, future.result()):
                pending[submit(follow)] = follow
    drain()
    return clips.records


def run_local(clips: _Clips, workers: int) -> list[dict]:
    """Jobs in this process (1 worker) or a pool of fresh processes (spawned: one engine each)."""
    if workers == 1:
        def inline(job: Job) -> Future:
            future = Future()
            future.set_result(run_job(job, clips.progress))
            return future

        return _schedule(clips, inline, lambda: None)
    # One BLAS thread per worker: the workers already fill the cores.
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")
    context = get_context("spawn")
    with context.Manager() as manager:
        queue = manager.Queue()
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            return _schedule(clips, lambda job: pool.submit(_run_job_reporting, job, queue), lambda: _drain(queue, clips.progress))


def _run_job_reporting(job: Job, queue) -> dict:
    return run_job(job, lambda *event: queue.put(event))


def _drain(queue, progress: Progress) -> None:
    while not queue.empty():
        progress(*queue.get())


def run_ray(clips: _Clips, address: str | None) -> list[dict]:
    """Jobs as Ray tasks on a cluster (`ray start --head` on one machine or many); a task whose
    worker dies is retried (a retried shard rewrites its files from its first frame)."""
    import ray
    from ray.util.queue import Queue

    try:
        environment = {name: os.environ.get(name, value) for name, value in ARROW_ENVIRONMENT.items()}
        ray.init(address=address, logging_level="ERROR", log_to_driver=False, runtime_env={"env_vars": environment})
    except (ConnectionError, ValueError) as error:
        raise UserError(f"cannot reach the Ray cluster at {address!r}: {error}") from None
    try:
        if clips.automatic_shards:  # enough shards for the cluster's CPUs
            cpus = int(ray.cluster_resources().get("CPU", 1))
            clips.min_shards = max(1, math.ceil(cpus / max(len(clips.clip_indices), 1)))
        queue = Queue()
        task = ray.remote(max_retries=3)(_run_job_on_ray)
        return _schedule(clips, lambda job: task.remote(job, queue).future(), lambda: _drain(queue, clips.progress))
    finally:
        ray.shutdown()


def _run_job_on_ray(job: Job, queue) -> dict:
    return run_job(job, lambda *event: queue.put(event))


def finish(root: Path, scenario: Scenario, records: list[dict]):
    """Write the manifest and the dataset card, then remove the run state."""
    from simgen.datasets import ClipRecord, finish_dataset
    from simgen.scan.sensor_rig import sensor_infos

    for leftover in root.rglob("*.tmp-*"):  # of workers that died (a Ray task retried elsewhere)
        leftover.unlink()
    manifest = finish_dataset(
        root,
        scenario.dataset.format,
        [ClipRecord.from_dict(r) for r in sorted(records, key=lambda r: r["clip_index"])],
        sensor_infos(scenario),
        scenario.model_dump(mode="json"),
        scenario.seed,
    )
    shutil.rmtree(root / WORK_DIR / "clips", ignore_errors=True)
    (root / WORK_DIR / "scenario.json").unlink(missing_ok=True)
    return manifest


def finish_written(root: Path):
    """A run killed after its manifest was written: the card if it is missing (the run state goes next)."""
    from simgen.datasets.manifest import read_manifest
    from simgen.datasets.write import write_card

    manifest = read_manifest(root)
    if not (root / CARD_NAME).exists():
        write_card(root, manifest)
    return manifest


def generate(
    scenario: Scenario,
    root: Path,
    workers: int = 1,
    executor: str = "local",
    address: str | None = None,
    resume: bool = False,
    overwrite: bool = False,
    progress: Progress | None = None,
    shard_frames: int = 0,
) -> dict:
    """Make the whole dataset; returns totals for the summary. `shard_frames`: frames per shard
    (0: automatic, enough shards for every worker, at most AUTO_SHARD_MAX_FRAMES frames each)."""
    started = time.perf_counter()
    root = Path(root)
    check_output_allowed(root)
    if root.exists() and not root.is_dir():
        raise UserError(f"{root}: exists and is not a directory")
    if shard_frames < 0:
        raise UserError(f"--shard-frames: {shard_frames} is negative (0: automatic)")
    created_root, created_work = not root.exists(), not (root / WORK_DIR).exists()
    root.mkdir(parents=True, exist_ok=True)
    lock = OutputLock(root)
    try:
        try:
            finished = prepare_output(root, scenario, resume, overwrite)
        except UserError:  # refused: leave the directory as it was
            if created_work:
                shutil.rmtree(root / WORK_DIR)
            if created_root:
                shutil.rmtree(root)
            raise
        done = done_clips(root) if resume and not finished else {}
        todo = [] if finished else [i for i in range(scenario.dataset.clips) if i not in done]
        min_shards = max(1, math.ceil(workers / max(len(todo), 1)))
        clips = _Clips(root, scenario.model_dump(mode="json"), todo, shard_frames, min_shards, progress or (lambda *_: None))
        if finished:
            manifest = finish_written(root)
            done = {c.clip_index: None for c in manifest.clips}
        else:
            if not todo:
                new = []
            elif executor == "ray":
                new = run_ray(clips, address)
            else:
                new = run_local(clips, workers)
            manifest = finish(root, scenario, list(done.values()) + new)
    finally:
        lock.release()
    shutil.rmtree(root / WORK_DIR, ignore_errors=True)
    return {
        "clips": len(manifest.clips),
        "frames": sum(c.frames for c in manifest.clips),
        "points": sum(c.points for c in manifest.clips),
        "boxes": sum(c.boxes for c in manifest.clips),
        "bytes": sum(f.bytes for f in manifest.files),
        "files": len(manifest.files),
        "resumed_clips": len(done),
        "seconds": time.perf_counter() - started,
    }
