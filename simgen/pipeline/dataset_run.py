"""`simgen generate`: clips -> datasets, on this machine's cores or on a Ray cluster, resumable.

A clip is made of jobs (`jobs`: its engine capture, frame-range shards, their assembly) that the
run's `schedule` hands to an `executor` (`local_pool` or `ray_cluster`) as their inputs become
ready; the run state (`run_state`, `.simgen/` in the output directory) records what is done.

Every frame depends only on (scenario, seed, clip index, frame index), so executors, worker
counts and shard sizes give byte-identical datasets, and `--resume` skips what is recorded done
(clips, captures, shards). The manifest is written once, when every clip is done. A lock file
stops a second run from writing into the same directory.
"""

from __future__ import annotations

import math
import shutil
import time
from pathlib import Path

from simgen.atomic import check_output_allowed
from simgen.errors import UserError
from simgen.pipeline.jobs import Progress
from simgen.pipeline.local_pool import local_pool
from simgen.pipeline.ray_cluster import ray_cluster
from simgen.pipeline.run_state import CARD_NAME, WORK_DIR, OutputLock, done_clips, prepare_output
from simgen.pipeline.schedule import Schedule, run_jobs
from simgen.scenario import Scenario


def finish(root: Path, scenario: Scenario, records: list[dict]):
    """Write the manifest and the dataset card, then remove the run state."""
    from simgen.datasets import ClipRecord, finish_dataset
    from simgen.scan.sensor import scenario_sensors

    for leftover in root.rglob("*.tmp-*"):  # of workers that died (a Ray task retried elsewhere)
        leftover.unlink()
    manifest = finish_dataset(
        root,
        scenario.dataset.format,
        [ClipRecord.from_dict(r) for r in sorted(records, key=lambda r: r["clip_index"])],
        scenario_sensors(scenario),
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


def run_clips(
    scenario: Scenario,
    root: Path,
    todo: list[int],
    executor: str,
    workers: int,
    address: str | None,
    shard_frames: int,
    progress: Progress,
) -> list[dict]:
    """Make the clips `todo` on the executor ("local": `workers` processes, "ray": the cluster at
    `address`); returns their records."""
    with (ray_cluster(address, progress) if executor == "ray" else local_pool(workers, progress)) as opened:
        min_shards = max(1, math.ceil(opened.cpus / max(len(todo), 1)))  # automatic shards: enough for every CPU
        schedule = Schedule(root, scenario.model_dump(mode="json"), todo, shard_frames, min_shards, progress)
        return run_jobs(schedule, opened)


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
        if finished:
            manifest = finish_written(root)
            done = {c.clip_index: None for c in manifest.clips}
        else:
            todo = [i for i in range(scenario.dataset.clips) if i not in done]
            progress = progress or (lambda *_: None)
            new = run_clips(scenario, root, todo, executor, workers, address, shard_frames, progress) if todo else []
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
