"""What `track` writes, frame by frame as the tracks become final, into a staging folder inside OUT that
replaces OUT's files only once the whole run has succeeded (bad input half-way leaves OUT as it was):

- `kitti/<clip>.txt`: KITTI tracking results (train.evaluation.kitti's lines, numbered by the clip's frame);
- `tracks.parquet`: the `tracks` table, a row per track and frame (TRACKS_SCHEMA, units in field metadata), a row
  group per ROW_GROUP_FRAMES frames of a clip, each first written alone under `.parts/` (what a resumed run keeps)
  and gathered into the table at the end;
- `mcap/<clip>/`: a ROS 2 bag (simgen.datasets.formats.mcap's writer: `<clip>.mcap` and rosbag2's metadata.yaml)
  with the frame's points and labels as simgen writes them, and `/simgen/tracks`: per frame DELETEALL, then
  per track a CUBE (namespace `tracks`, id = track id, one colour per id, dying tracks faint), its id as
  TEXT_VIEW_FACING (`track_ids`) and its trajectory so far as a LINE_STRIP (`trajectories`, its last
  TRAIL_FRAMES boxes; a track not shown for TRAIL_FRAMES frames starts a new one).
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections import deque
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from simgen.datasets.formats.mcap import (
    SCHEMAS,
    BagWriter,
    PointLayout,
    header_message,
    marker_array_message,
    marker_message,
    nanoseconds,
    pose_message,
    vector_message,
)
from simgen.datasets.frame import Frame
from train.evaluation.kitti import kitti_lines
from train.tracking.types import DYING, STATES, TrackedFrame

TRACKS_TOPIC = "/simgen/tracks"
TRAIL_FRAMES = 100  # a trajectory's line strip: its last 100 frames (10 s at 10 Hz)
ROW_GROUP_FRAMES = 100  # the tracks table is written 100 frames at a time: memory flat in a clip's length
LINE_WIDTH_M = 0.1
TEXT_HEIGHT_M = 0.5


def _field(name: str, type_: pa.DataType, doc: str, unit: str = "") -> pa.Field:
    return pa.field(name, type_, nullable=False, metadata={"doc": doc, "unit": unit})


TRACKS_SCHEMA = pa.schema([
    _field("clip", pa.string(), "clip id"),
    _field("frame", pa.int32(), "frame index in the clip"),
    _field("time_s", pa.float64(), "game time the box describes (the frame's label time)", "s"),
    _field("track_id", pa.int64(), "track id, unique in the clip"),
    *(_field(n, pa.float32(), f"box {d}, pitch frame", "m") for n, d in (
        ("x", "centre x"), ("y", "centre y"), ("z", "centre z"), ("length", "length"), ("width", "width"),
        ("height", "height"))),
    _field("yaw", pa.float32(), "box heading about z, from +x", "rad"),
    _field("score", pa.float32(), "the track's score: mean of its matched detections' scores"),
    _field("state", pa.dictionary(pa.int8(), pa.string()), f"the track's state: {', '.join(STATES)}"),
])


def track_markers(tracked: TrackedFrame, trails: dict[int, deque], stamp_ns: int):
    """The MarkerArray of one frame's tracks; `trails` (track id -> its last TRAIL_FRAMES centres) is updated."""
    from simgen.view.trajectories import id_colour  # the drawing stack (numba) only when a bag is written


    header = header_message(stamp_ns)
    markers = [marker_message(header, "tracks", 0, 0, 3)]
    states = tracked.states if tracked.states is not None else np.zeros(len(tracked.ids), np.int8)
    for box, track, state in zip(tracked.boxes.tolist(), tracked.ids.tolist(), states.tolist()):
        x, y, z, length, width, height, yaw = box
        colour = (*id_colour(track), 0.3 if state == DYING else 0.8)
        trail = trails.setdefault(track, deque(maxlen=TRAIL_FRAMES))
        trail.append((x, y, 0.05))
        markers += [
            marker_message(header, "tracks", track, 1, 0, pose_message(x, y, z, yaw),
                           vector_message(length, width, height), colour, STATES[state]),
            marker_message(header, "track_ids", track, 9, 0, pose_message(x, y, z + height / 2 + TEXT_HEIGHT_M),
                           vector_message(z=TEXT_HEIGHT_M), colour, str(track)),
            marker_message(header, "trajectories", track, 4, 0, scale=vector_message(LINE_WIDTH_M), color=colour,
                           points=list(trail)),
        ]
    return marker_array_message(markers)


class ClipBag:
    """One clip's output bag: each frame's points and labels, then its tracks on TRACKS_TOPIC."""

    def __init__(self, path: Path, sensors: Sequence, layout: PointLayout) -> None:
        self.writer = BagWriter(path, sensors, layout)
        self.trails: dict[int, deque] = {}
        self.last_seen: dict[int, int] = {}  # track id -> the last frame (count in the bag) it was shown in
        self.frames = 0

    def add(self, frame: Frame, tracked: TrackedFrame) -> None:
        self.writer.add(frame)
        stamp_ns = nanoseconds(frame.label_time_s)
        self.writer.write(TRACKS_TOPIC, SCHEMAS[1], track_markers(tracked, self.trails, stamp_ns), stamp_ns)
        self.frames += 1
        self.last_seen.update(dict.fromkeys(tracked.ids.tolist(), self.frames))
        if self.frames % TRAIL_FRAMES == 0:  # the trails of tracks not shown for TRAIL_FRAMES frames: memory flat
            gone = [track for track, seen in self.last_seen.items() if self.frames - seen >= TRAIL_FRAMES]
            for track in gone:
                del self.trails[track], self.last_seen[track]

    def finish(self) -> None:
        self.writer.finish()


def track_rows(clip: str, index: int, time_s: float, tracked: TrackedFrame) -> dict[str, list]:
    """One frame's rows of the `tracks` table, by column."""
    n, boxes = len(tracked.ids), tracked.boxes
    states = tracked.states if tracked.states is not None else np.zeros(n, np.int8)
    columns = {"clip": [clip] * n, "frame": [index] * n, "time_s": [time_s] * n, "track_id": tracked.ids.tolist()}
    columns |= {name: boxes[:, k].tolist() for k, name in enumerate(("x", "y", "z", "length", "width", "height",
                                                                   "yaw"))}
    return columns | {"score": tracked.scores.tolist(), "state": [STATES[s] for s in states.tolist()]}


class TrackOutputs:
    """The run's files, written into `staging` clip by clip; `publish` moves them into OUT."""

    def __init__(self, staging: Path, sensors: Sequence, layout: PointLayout, bags: bool, recording=None) -> None:
        """`recording`: where every final frame goes too (train.track.rerun_tracks.RerunTracks), or None."""
        self.staging, self.sensors, self.layout, self.bags = staging, sensors, layout, bags
        self.recording = recording
        (staging / "kitti").mkdir(exist_ok=True)
        if bags:
            (staging / "mcap").mkdir(exist_ok=True)
        self.parts = staging / ".parts"
        self.parts.mkdir(exist_ok=True)
        self.files = contextlib.ExitStack()
        self.clip: str | None = None
        self.clips = 0  # started

    def start_clip(self, clip: str) -> None:
        """Start (or start again: a resumed run) the next clip's files."""
        self.clip, self.rows, self.frames = clip, {name: [] for name in TRACKS_SCHEMA.names}, 0
        for part in self.parts.glob(f"{self.clips:04d}_*.parquet"):
            part.unlink()
        self.kitti = self.files.enter_context(open(self.staging / "kitti" / f"{clip}.txt", "w"))
        if self.bags:
            shutil.rmtree(self.staging / "mcap" / clip, ignore_errors=True)
            self.bag = ClipBag(self.staging / "mcap" / clip, self.sensors, self.layout)
        if self.recording is not None:
            self.recording.start_clip(clip)
        self.clips += 1

    def add(self, frame: Frame, tracked: TrackedFrame) -> None:
        """One final frame of the current clip: the dataset's (or bag's) frame and its tracks."""
        self.kitti.write("".join(line + "\n" for line in kitti_lines([tracked], numbers=[frame.index])))
        for name, values in track_rows(frame.clip, frame.index, frame.label_time_s, tracked).items():
            self.rows[name] += values
        self.frames += 1
        if self.frames % ROW_GROUP_FRAMES == 0:
            self._write_rows()
        if self.bags:
            self.bag.add(frame, tracked)
        if self.recording is not None:
            self.recording.add(frame, tracked)

    def _write_rows(self) -> None:
        if self.rows["clip"]:
            part = self.parts / f"{self.clips - 1:04d}_{(self.frames - 1) // ROW_GROUP_FRAMES:06d}.parquet"
            pq.write_table(pa.table(self.rows, schema=TRACKS_SCHEMA), part)
        self.rows = {name: [] for name in TRACKS_SCHEMA.names}

    def end_clip(self) -> None:
        self._write_rows()
        if self.bags:
            self.bag.finish()
        self.files.close()

    def close(self) -> None:
        """The tracks table from its parts, a row group each, in order; the parts removed."""
        with pq.ParquetWriter(self.staging / "tracks.parquet", TRACKS_SCHEMA) as table:
            for part in sorted(self.parts.glob("*.parquet")):
                table.write_table(pq.read_table(part, schema=TRACKS_SCHEMA))
        shutil.rmtree(self.parts)


PARTIAL = ".track-partial"  # the staging folder in OUT: what a killed run leaves for `--resume`


@contextlib.contextmanager
def staged(out: Path, resume: bool) -> Iterator[Path]:
    """A staging folder in OUT (an interrupted run's, kept with `resume`); on success its files replace OUT's, on
    any error it is removed (and so is OUT, if this made it)."""
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    staging = out / PARTIAL
    if not resume:
        shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(exist_ok=True)
    try:
        yield staging
        for path in sorted(staging.iterdir()):
            target = out / path.name
            if target.is_dir() and path.is_dir():
                shutil.rmtree(target)
            os.replace(path, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    shutil.rmtree(staging, ignore_errors=True)
