"""Motion clips on disk: one Parquet file, one row per (frame, humanoid), zstd.

Columns: frame, time_s, track_id, team, role, jersey, keypoints_m (12 x (x, y, z) flattened, in
the order of `simgen.vocab.KEYPOINT_NAMES`), engine_position_m, ball_m, placed_s and ball_placed_s
(when the engine placed the humanoid or the ball since the frame before; NaN: not placed),
game_mode. Units and the
pitch frame are in the field and schema metadata, so pandas, polars and duckdb read it as is.
`write_clip_arrays` / `read_clip_arrays` keep a clip as uncompressed `.npy` arrays instead, for
`simgen generate`'s run state: its shards map them and touch only the frames they render.
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
from simgen.motion.clip import GAME_MODES, MotionClip
from simgen.vocab import KEYPOINT_NAMES, NUM_KEYPOINTS

MOTION_SCHEMA_VERSION = 2  # 2: placements and game mode
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
        _field(
            "placed_s",
            pa.float64(),
            "game time (s) the engine placed the humanoid (a restart) since the frame before; NaN: not placed",
        ),
        _field(
            "ball_placed_s",
            pa.float64(),
            "game time (s) the engine placed the ball since the frame before; NaN: not placed",
        ),
        _field(
            "game_mode", pa.int8(), "the engine's game mode: " + ", ".join(f"{i} {m}" for i, m in enumerate(GAME_MODES))
        ),
    ]
)


PER_ROW_COLUMNS = {"time_s": np.float64, "placed_s": np.float64, "ball_placed_s": np.float64, "game_mode": np.int8}
# fixed-size list columns, widths
PER_ROW_LISTS = {"keypoints_m": NUM_KEYPOINTS * 3, "engine_position_m": 3, "ball_m": 3}


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
        "placed_s": np.asarray(clip.placed_s, np.float64).reshape(-1),
        "ball_placed_s": np.repeat(clip.ball_placed_s, humanoids),
        "game_mode": np.repeat(clip.game_mode, humanoids),
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
        engine_position_m=clip.engine_position_m[start:stop], placed_s=clip.placed_s[start:stop],
        ball_placed_s=clip.ball_placed_s[start:stop], game_mode=clip.game_mode[start:stop],
    )


def read_clip(path: str | Path) -> MotionClip:
    """Read a motion clip a row group at a time into arrays allocated once (a whole match's table at once
    would cost several times its arrays in memory); a file that is not one of ours is a one-line `UserError`."""
    path = Path(path)
    try:
        parquet = pq.ParquetFile(path)
        raw = (parquet.schema_arrow.metadata or {}).get(b"simgen.motion")
        if raw is None:
            raise UserError(f"{path}: not a simgen motion clip (no simgen.motion metadata)")
        metadata = json.loads(raw)
        if metadata.get("schema_version") != MOTION_SCHEMA_VERSION:
            raise UserError(
                f"{path}: motion schema version {metadata.get('schema_version')}, "
                f"this simgen reads {MOTION_SCHEMA_VERSION}"
            )
        rows = parquet.metadata.num_rows
        if rows == 0:
            raise UserError(f"{path}: a motion clip without frames")
        frame = np.empty(rows, np.int32)
        per_column = {name: np.empty(rows, dtype) for name, dtype in PER_ROW_COLUMNS.items()}
        per_row = {name: np.empty((rows, width), np.float32) for name, width in PER_ROW_LISTS.items()}
        first = None  # the first row group: the roster
        done = 0
        for group_index in range(parquet.num_row_groups):
            group = parquet.read_row_group(group_index)
            first = group if first is None else first
            stop = done + group.num_rows
            frame[done:stop] = group["frame"].to_numpy()
            for name in PER_ROW_COLUMNS:
                per_column[name][done:stop] = group[name].to_numpy()
            for name, width in PER_ROW_LISTS.items():
                per_row[name][done:stop] = group[name].combine_chunks().flatten().to_numpy().reshape(-1, width)
            done = stop
    except FileNotFoundError:
        raise UserError(f"{path}: no such motion clip") from None
    except (OSError, pa.ArrowException) as error:
        raise UserError(f"{path}: not a readable Parquet motion clip ({error})") from None
    except (KeyError, ValueError) as error:  # a column missing or of another width
        raise UserError(
            f"{path}: not a simgen motion clip "
            f"({type(error).__name__}: {str(error).splitlines()[0] if str(error) else error!r})"
        ) from None
    frames = int(frame.max()) + 1
    humanoids = rows // max(frames, 1)
    if (
        humanoids == 0
        or frames * humanoids != rows
        or not np.array_equal(frame, np.repeat(np.arange(frames), humanoids))
    ):
        raise UserError(f"{path}: rows are not whole frames of the same humanoids")
    roster = first.slice(0, humanoids)  # whole frames of the same humanoids: frame 0's rows hold the roster
    capture_hz = metadata.pop("capture_hz")
    for key in ("schema_version", "pitch_frame", "keypoint_names"):
        metadata.pop(key, None)
    return MotionClip(
        time_s=per_column["time_s"][::humanoids].copy(),
        keypoints_m=per_row["keypoints_m"].reshape(frames, humanoids, NUM_KEYPOINTS, 3),
        ball_m=per_row["ball_m"][::humanoids].copy(),
        engine_position_m=per_row["engine_position_m"].reshape(frames, humanoids, 3),
        track_id=roster["track_id"].to_numpy(),
        team=np.array(roster["team"].to_pylist()),
        role=np.array(roster["role"].to_pylist()),
        jersey=roster["jersey"].to_numpy(),
        capture_hz=capture_hz,
        metadata=metadata,
        placed_s=per_column["placed_s"].reshape(frames, humanoids),
        ball_placed_s=per_column["ball_placed_s"][::humanoids].copy(),
        game_mode=per_column["game_mode"][::humanoids].copy(),
    )


# MotionClip fields with a frame axis
FRAME_ARRAYS = ("time_s", "keypoints_m", "ball_m", "engine_position_m", "placed_s", "ball_placed_s", "game_mode")
ROSTER = ("track_id", "team", "role", "jersey")  # MotionClip fields with a humanoid axis only


def write_clip_arrays(clip: MotionClip, directory: str | Path) -> Path:
    """The clip as uncompressed arrays for `read_clip_arrays` to map: one `.npy` per field with a
    frame axis and `clip.json` (roster, capture rate, metadata), each file written atomically.
    `simgen generate` keeps a captured clip so between its capture and its shards."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for name in FRAME_ARRAYS:
        with atomic_path(directory / f"{name}.npy") as tmp, open(tmp, "wb") as file:
            np.save(file, getattr(clip, name), allow_pickle=False)
    roster = {name: getattr(clip, name).tolist() for name in ROSTER}
    with atomic_path(directory / "clip.json") as tmp:
        tmp.write_text(json.dumps({**roster, "capture_hz": clip.capture_hz, "metadata": clip.metadata}, sort_keys=True))
    return directory


def read_clip_arrays(directory: str | Path) -> MotionClip:
    """A clip `write_clip_arrays` wrote, its per-frame arrays memory-mapped read-only: a shard of a
    whole match keeps in memory only the frames it renders (a match's motion is about 200 MiB)."""
    directory = Path(directory)
    try:
        info = json.loads((directory / "clip.json").read_text())
        arrays = {name: np.load(directory / f"{name}.npy", mmap_mode="r", allow_pickle=False) for name in FRAME_ARRAYS}
    except (OSError, ValueError) as error:  # missing, truncated or foreign files (JSONDecodeError is a ValueError)
        raise UserError(
            f"{directory}: not a readable motion capture "
            f"({type(error).__name__}: {(str(error).splitlines() or [''])[0]})"
        ) from None
    if not isinstance(info, dict) or not {"capture_hz", "metadata"} <= info.keys():
        raise UserError(f"{directory}: a motion capture without its clip.json fields")
    humanoids = arrays["keypoints_m"].shape[1] if arrays["keypoints_m"].ndim == 4 else -1
    if len({len(array) for array in arrays.values()}) != 1 or any(
        len(info.get(name, ())) != humanoids for name in ROSTER
    ):
        raise UserError(f"{directory}: a motion capture whose arrays disagree on frames or humanoids")
    return MotionClip(
        **arrays,
        track_id=np.array(info["track_id"], dtype=np.int32),
        team=np.array(info["team"]),
        role=np.array(info["role"]),
        jersey=np.array(info["jersey"], dtype=np.int16),
        capture_hz=info["capture_hz"],
        metadata=info["metadata"],
    )
