"""Motion clips on disk: one Parquet file, one row per (frame, humanoid), zstd.

Columns: frame, time_s, track_id, team, role, jersey, keypoints_m (12 x (x, y, z) flattened, in
the order of `simgen.vocab.KEYPOINT_NAMES`), engine_position_m, ball_m. Units and the
pitch frame are in the field and schema metadata, so pandas, polars and duckdb read it as is.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from simgen.atomic import atomic_path
from simgen.errors import UserError
from simgen.motion.clip import MotionClip
from simgen.vocab import KEYPOINT_NAMES, NUM_KEYPOINTS

MOTION_SCHEMA_VERSION = 1
PITCH_FRAME = "pitch: origin at the centre spot, x towards the right team's goal, y left, z up; metres"


def _field(name: str, type_: pa.DataType, doc: str) -> pa.Field:
    return pa.field(name, type_, nullable=False, metadata={"doc": doc})


SCHEMA = pa.schema(
    [
        _field("frame", pa.int32(), "frame index in the clip"),
        _field("time_s", pa.float64(), "game time since kick-off, seconds"),
        _field("track_id", pa.int32(), "humanoid id, stable over the clip"),
        _field("team", pa.dictionary(pa.int8(), pa.string()), "left, right or official"),
        _field("role", pa.dictionary(pa.int8(), pa.string()), "GK, CB, ... or referee, linesman"),
        _field("jersey", pa.int16(), "shirt number; -1 when the engine has none"),
        _field(
            "keypoints_m",
            pa.list_(pa.float32(), NUM_KEYPOINTS * 3),
            "12 body parts x (x, y, z), metres, pitch frame, order: " + ", ".join(KEYPOINT_NAMES),
        ),
        _field(
            "engine_position_m",
            pa.list_(pa.float32(), 3),
            "the engine's own player position (x, y, z), metres; NaN between engine steps and for officials",
        ),
        _field("ball_m", pa.list_(pa.float32(), 3), "ball centre (x, y, z), metres"),
    ]
)


def _fixed_list(values: np.ndarray, width: int) -> pa.FixedSizeListArray:
    flat = pa.array(np.ascontiguousarray(values, dtype=np.float32).reshape(-1))
    return pa.FixedSizeListArray.from_arrays(flat, width)


def clip_to_table(clip: MotionClip, first_frame: int = 0) -> pa.Table:
    """The clip's rows; frames numbered from `first_frame` (a part of a longer clip)."""
    frames, humanoids = clip.num_frames, clip.num_humanoids
    columns = {
        "frame": np.repeat(np.arange(first_frame, first_frame + frames, dtype=np.int32), humanoids),
        "time_s": np.repeat(clip.time_s, humanoids),
        "track_id": np.tile(clip.track_id, frames),
        "team": pa.array(np.tile(clip.team, frames)).dictionary_encode(),
        "role": pa.array(np.tile(clip.role, frames)).dictionary_encode(),
        "jersey": np.tile(clip.jersey, frames),
        "keypoints_m": _fixed_list(clip.keypoints_m, NUM_KEYPOINTS * 3),
        "engine_position_m": _fixed_list(clip.engine_position_m, 3),
        "ball_m": _fixed_list(np.repeat(clip.ball_m, humanoids, axis=0), 3),
    }
    metadata = {
        "schema_version": MOTION_SCHEMA_VERSION,
        "capture_hz": clip.capture_hz,
        "pitch_frame": PITCH_FRAME,
        "keypoint_names": list(KEYPOINT_NAMES),
        **clip.metadata,
    }
    schema = SCHEMA.with_metadata({"simgen.motion": json.dumps(metadata, sort_keys=True)})
    return pa.Table.from_pydict(columns, schema=schema)


def write_clip(clip: MotionClip, path: str | Path) -> Path:
    """Write atomically (temporary name, then rename); row groups of whole frames, built one at a
    time (a whole match's table at once would cost several times its arrays in memory)."""
    path = Path(path)
    frames_per_group = max(1, 4096 // max(clip.num_humanoids, 1))
    starts = range(0, max(clip.num_frames, 1), frames_per_group)
    with atomic_path(path) as tmp:
        writer = None
        for start in starts:
            group = clip_to_table(_frames(clip, start, start + frames_per_group), first_frame=start)
            writer = writer or pq.ParquetWriter(tmp, group.schema, compression="zstd")
            writer.write_table(group, row_group_size=max(len(group), 1))
        writer.close()
    return path


def _frames(clip: MotionClip, start: int, stop: int) -> MotionClip:
    """Frames start .. stop - 1 of a clip (views)."""
    return dataclasses.replace(
        clip, time_s=clip.time_s[start:stop], keypoints_m=clip.keypoints_m[start:stop], ball_m=clip.ball_m[start:stop],
        engine_position_m=clip.engine_position_m[start:stop],
    )


def read_clip(path: str | Path) -> MotionClip:
    """Read a motion clip; a file that is not one of ours is a one-line `UserError`."""
    path = Path(path)
    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise UserError(f"{path}: no such motion clip") from None
    except (OSError, pa.ArrowException) as error:
        raise UserError(f"{path}: not a readable Parquet motion clip ({error})") from None
    raw = (table.schema.metadata or {}).get(b"simgen.motion")
    if raw is None:
        raise UserError(f"{path}: not a simgen motion clip (no simgen.motion metadata)")
    metadata = json.loads(raw)
    if metadata.get("schema_version") != MOTION_SCHEMA_VERSION:
        raise UserError(
            f"{path}: motion schema version {metadata.get('schema_version')}, "
            f"this simgen reads {MOTION_SCHEMA_VERSION}"
        )
    frame = table["frame"].to_numpy()
    frames = int(frame.max()) + 1 if len(frame) else 0
    humanoids = len(frame) // max(frames, 1)
    if frames * humanoids != len(frame) or not np.array_equal(frame, np.repeat(np.arange(frames), humanoids)):
        raise UserError(f"{path}: rows are not whole frames of the same humanoids")

    def per_frame(name: str, width: int) -> np.ndarray:
        values = table[name].combine_chunks().flatten().to_numpy()
        return values.reshape(frames, humanoids, width)

    first = table.slice(0, humanoids)
    capture_hz = metadata.pop("capture_hz")
    for key in ("schema_version", "pitch_frame", "keypoint_names"):
        metadata.pop(key, None)
    return MotionClip(
        time_s=table["time_s"].to_numpy()[::humanoids].copy(),
        keypoints_m=per_frame("keypoints_m", NUM_KEYPOINTS * 3).reshape(frames, humanoids, NUM_KEYPOINTS, 3),
        ball_m=per_frame("ball_m", 3)[:, 0].copy(),
        engine_position_m=per_frame("engine_position_m", 3),
        track_id=first["track_id"].to_numpy(),
        team=np.array(first["team"].to_pylist()),
        role=np.array(first["role"].to_pylist()),
        jersey=first["jersey"].to_numpy(),
        capture_hz=capture_hz,
        metadata=metadata,
    )
