"""The three kinds of job a dataset is made of, each a plain-data `Job` that runs in this process, a
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
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from simgen.datasets.formats import dataset_format  # names only: imports no writer
from simgen.pipeline.memory import release_memory
from simgen.pipeline.run_state import (
    clip_marker,
    motion_path,
    plan_path,
    read_plan,
    shard_marker,
    shard_root,
    write_json,
)
from simgen.scenario import Scenario

#: Events: "capture" (motion frames to capture), "captured" (more captured), "start" (frames of the
#: clip), "frame" (more rendered), "done" (frames of the finished clip); with the clip index.
Progress = Callable[[str, int, int], None]
AUTO_SHARD_MAX_FRAMES = 3000  # automatic shards: at most 5 minutes of 10 Hz frames lost to a kill
CAPTURE_REPORT_FRAMES = 50  # motion frames captured between progress reports


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
    write_json(plan_path(root, job.clip_index), plan)
    return plan


def run_shard(job: Job, progress: Progress) -> dict:
    """Render and write one shard of a clip, frame by frame; returns its `ClipRecord` as a dict
    (the clip's own when the shard is the whole clip)."""
    from simgen.datasets.write import ClipWriter
    from simgen.motion.clip_io import read_clip_arrays
    from simgen.pipeline.clip import clip_name, frame_boxes, label_sizes, render_frames
    from simgen.scan.sensor import scenario_sensors

    scenario = Scenario.model_validate(job.scenario)
    root = Path(job.root)
    first, stop = job.frames
    plan = read_plan(root, job.clip_index)
    whole = len(plan["shards"]) == 1
    fmt = scenario.dataset.format
    in_place = writes_in_place(fmt, len(plan["shards"]))
    if in_place:
        target, target_format = root, fmt
    else:
        target, target_format = shard_root(root, job.clip_index, first), "parquet"
        target.mkdir(parents=True, exist_ok=True)
    clip = read_clip_arrays(motion_path(root, job.clip_index))
    with ClipWriter(
        target, target_format, clip_name(job.clip_index), job.clip_index, scenario_sensors(scenario), first
    ) as writer:
        sizes = label_sizes(scenario, clip)  # over the whole clip: once per shard, for the seam and the frames
        if in_place and first > 0:  # the seam's frame pair, which no shard written in place would count
            writer.after(clip.track_id, frame_boxes(scenario, clip, sizes, first - 1))
        for frame in render_frames(scenario, clip, job.clip_index, first, stop, sizes):
            writer.add(frame)
            progress("frame", job.clip_index, 1)
        record = writer.close().to_dict()
    write_json(clip_marker(root, job.clip_index) if whole else shard_marker(root, job.clip_index, first), record)
    return record


def run_assemble(job: Job, progress: Progress) -> dict:
    """Join a clip's shards: stream the partial clips into the final files in frame order (or, for
    formats whose shards wrote in place, gather their records); returns the clip's `ClipRecord`."""
    from simgen.datasets.formats.parquet import labelled_frames
    from simgen.datasets.records import ClipRecord
    from simgen.datasets.write import ClipWriter
    from simgen.labels.statistics import LabelStatistics
    from simgen.pipeline.clip import clip_name
    from simgen.scan.sensor import scenario_sensors

    scenario = Scenario.model_validate(job.scenario)
    root = Path(job.root)
    plan = read_plan(root, job.clip_index)
    shards = [
        ClipRecord.from_dict(json.loads(shard_marker(root, job.clip_index, first).read_text()))
        for first, _ in plan["shards"]
    ]
    fmt, name = scenario.dataset.format, clip_name(job.clip_index)
    if writes_in_place(fmt, len(shards)):
        labels = LabelStatistics.empty()
        for shard in shards:
            labels = labels.merged(LabelStatistics.from_dict(shard.labels))
        record = ClipRecord(
            fmt,
            name,
            job.clip_index,
            sum(s.frames for s in shards),
            sum(s.points for s in shards),
            sum(s.boxes for s in shards),
            shards[0].start_s,
            tuple(sorted((f for s in shards for f in s.files), key=lambda f: f.path)),
            labels.to_dict(),
        )
    else:
        with ClipWriter(root, fmt, name, job.clip_index, scenario_sensors(scenario)) as writer:
            for first, _ in plan["shards"]:
                for frame in labelled_frames(shard_root(root, job.clip_index, first), name):
                    writer.add(frame)
            record = writer.close()
    write_json(clip_marker(root, job.clip_index), record.to_dict())
    return record.to_dict()


RUNNERS = {"capture": run_capture, "shard": run_shard, "assemble": run_assemble}


def run_job(job: Job, progress: Progress | None = None) -> dict:
    try:
        return RUNNERS[job.kind](job, progress or (lambda *_: None))
    finally:
        release_memory()
