"""`simgen generate`: clips -> datasets, on this machine's cores or on a Ray cluster, resumable.

The unit of work is a clip: capture its motion in the engine, render and label its frames, write
its files (`simgen.datasets.write_clip`), then record it as done (`.simgen/clips/NNNN.json`,
written last and atomically). A clip's output depends only on (scenario, seed, clip index), so
executors and worker counts give byte-identical datasets, and `--resume` simply skips the clips
already recorded. The manifest is written once, when every clip is done. A lock file stops a
second run from writing into the same directory.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Callable

from simgen.atomic import atomic_path, check_output_allowed
from simgen.errors import UserError
from simgen.scenario import Scenario

WORK_DIR = ".simgen"  # run state inside the output directory; removed when the dataset is finished
CARD_NAME = "README.md"  # simgen.datasets.write.CARD_NAME (not imported: workers import this module light)
Progress = Callable[[str, int, int], None]  # (event "start" | "frame" | "done", clip index, number)


@dataclass(frozen=True)
class ClipJob:
    """Everything a worker needs for one clip (plain data: it crosses process and Ray boundaries)."""

    scenario: dict  # Scenario.model_dump(mode="json")
    clip_index: int
    root: str


def run_clip(job: ClipJob, progress: Progress | None = None) -> dict:
    """Make one clip from scratch; returns its `ClipRecord` as a dict (also saved as its done-marker)."""
    from simgen.datasets import write_clip
    from simgen.motion.engine import capture_motion
    from simgen.pipeline.clip import engine_seed, frame_count, render_clip
    from simgen.scan.sensor_rig import sensor_infos

    scenario = Scenario.model_validate(job.scenario)
    notify = progress or (lambda *_: None)
    clip = capture_motion(scenario.motion, engine_seed(scenario, job.clip_index))
    notify("start", job.clip_index, frame_count(scenario, clip))
    frames = []
    for frame in render_clip(scenario, clip, job.clip_index):
        frames.append(frame)
        notify("frame", job.clip_index, 1)
    root = Path(job.root)
    sensors = sensor_infos(scenario)
    record = write_clip(root, scenario.dataset.format, frames, sensors, job.clip_index).to_dict()
    with atomic_path(root / WORK_DIR / "clips" / f"{job.clip_index:04d}.json") as tmp:
        tmp.write_text(json.dumps(record, sort_keys=True))
    notify("done", job.clip_index, len(frames))
    return record


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
        shutil.rmtree(root / WORK_DIR / "clips", ignore_errors=True)
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
    for marker in sorted((root / WORK_DIR / "clips").glob("*.json")):
        record = json.loads(marker.read_text())
        records[record["clip_index"]] = record
    return records


def run_local(jobs: list[ClipJob], workers: int, progress: Progress) -> list[dict]:
    """Clips in this process (1 worker) or a pool of fresh processes (spawned: one engine each)."""
    if workers == 1:
        return [run_clip(job, progress) for job in jobs]
    # One BLAS thread per worker: the workers already fill the cores.
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")
    context = get_context("spawn")
    with context.Manager() as manager:
        queue = manager.Queue()
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            pending = {pool.submit(_run_clip_reporting, job, queue) for job in jobs}
            results = []
            while pending:
                finished, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                _drain(queue, progress)
                results += [future.result() for future in finished]
            _drain(queue, progress)
    return results


def _run_clip_reporting(job: ClipJob, queue) -> dict:
    return run_clip(job, lambda *event: queue.put(event))


def _drain(queue, progress: Progress) -> None:
    while not queue.empty():
        progress(*queue.get())


def run_ray(jobs: list[ClipJob], address: str | None, progress: Progress) -> list[dict]:
    """Clips as Ray tasks on a cluster (`ray start --head` on one machine or many); a task whose
    worker dies is retried."""
    import ray
    from ray.util.queue import Queue

    try:
        ray.init(address=address, logging_level="ERROR", log_to_driver=False)
    except (ConnectionError, ValueError) as error:
        raise UserError(f"cannot reach the Ray cluster at {address!r}: {error}") from None
    try:
        queue = Queue()
        task = ray.remote(max_retries=3)(_run_clip_on_ray)
        pending = [task.remote(job, queue) for job in jobs]
        results = []
        while pending:
            finished, pending = ray.wait(pending, num_returns=1, timeout=0.2)
            while not queue.empty():
                progress(*queue.get())
            results += ray.get(finished)
        while not queue.empty():
            progress(*queue.get())
        return results
    finally:
        ray.shutdown()


def _run_clip_on_ray(job: ClipJob, queue) -> dict:
    return run_clip(job, lambda *event: queue.put(event))


def finish(root: Path, scenario: Scenario, records: list[dict]):
    """Write the manifest and the dataset card, then remove the run state."""
    from simgen.datasets import ClipRecord, finish_dataset
    from simgen.scan.sensor_rig import sensor_infos

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
) -> dict:
    """Make the whole dataset; returns totals for the summary."""
    started = time.perf_counter()
    root = Path(root)
    check_output_allowed(root)
    if root.exists() and not root.is_dir():
        raise UserError(f"{root}: exists and is not a directory")
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
        payload = scenario.model_dump(mode="json")
        jobs = [ClipJob(payload, i, str(root)) for i in range(scenario.dataset.clips) if i not in done]
        notify = progress or (lambda *_: None)
        if finished:
            manifest = finish_written(root)
            done = {c.clip_index: None for c in manifest.clips}
        elif executor == "ray":
            new = run_ray(jobs, address, notify) if jobs else []
        else:
            new = run_local(jobs, workers, notify)
        if not finished:
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
