"""The `parquet` format (the default): its writer, reader and plug-in. A file per clip and table, zstd, laid out
like Waymo Open Dataset v2; the only format that keeps every shot's bookkeeping and each box's points.

`<table>/<clip id>/part-0.parquet` for `frames`, `points` and `boxes` (every row holds its `clip`
and `frame`), `sensors/part-0.parquet` and `units/part-0.parquet` once per dataset
(`simgen.datasets.schema`). `points` has row groups of `POINTS_FRAMES_PER_GROUP` frames (row group g
holds frames 10 g .. 10 g + 9; a writer keeps about 10 KiB of metadata per row group, so a group per
frame would grow a whole match's writer by 0.5 GiB);
`frames` and `boxes` have row groups of whole frames. Writer options are fixed and no time stamp is written, so
the same frames give the same bytes. Pages carry CRC checksums, checked on read: a second guard
behind the manifest's sha256 (which `verify=False` skips).
"""

from __future__ import annotations

import contextlib
import functools
import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from simgen.atomic import atomic_path
from simgen.datasets import markdown
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.frame import Frame, class_names
from simgen.datasets.limits import (
    MAX_BOXES_PER_FRAME,
    check_boxes,
    check_declared_sizes,
    check_points,
    max_points_per_frame,
)
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import ClipRecord, FileRecord, record_file
from simgen.datasets.schema import (
    BOX_FIELDS,
    CLIP_TABLES,
    METADATA_KEY,
    SCHEMA_VERSION,
    SENSOR_POSE_COLUMNS,
    TABLES,
    units_rows,
    with_table_metadata,
)
from simgen.datasets.verify import DatasetFiles, Problem
from simgen.errors import UserError
from simgen.vocab import NUM_KEYPOINTS

if TYPE_CHECKING:
    from simgen.labels.boxes import FrameLabels
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor


FRAMES_PER_GROUP = 1000  # row groups of `frames` and `boxes`
POINTS_FRAMES_PER_GROUP = 10  # row groups of `points`
OPEN_CLIPS = 4  # clips whose frames and boxes tables the reader keeps
SENSORS_PATH = "sensors/part-0.parquet"
UNITS_PATH = "units/part-0.parquet"


def table_path(table: str, clip: str) -> str:
    """A per-clip table's file (a plain folder per clip, not hive-style: the clip is a column inside)."""
    return f"{table}/{clip}/part-0.parquet"


def _clip_column(clip: str, rows: int) -> pa.DictionaryArray:
    return pa.DictionaryArray.from_arrays(pa.array(np.zeros(rows, np.int32)), pa.array([clip], pa.string()))


def _fixed_list(values: NDArray, width: int) -> pa.FixedSizeListArray:
    flat = pa.array(np.ascontiguousarray(values, dtype=np.float32).reshape(-1))
    return pa.FixedSizeListArray.from_arrays(flat, width)


def _categories(per_frame: list[NDArray[np.str_]]) -> pa.DictionaryArray:
    """Strings dictionary-encoded in order of first appearance (deterministic)."""
    values = [str(v) for values in per_frame for v in values]
    return pa.array(values, pa.dictionary(pa.int8(), pa.string()))


def _table(name: str, columns: dict) -> pa.Table:
    return pa.Table.from_pydict(columns, schema=with_table_metadata(TABLES[name], name))


def frame_row(frame: LabelledFrame) -> dict:
    """A frame's row of the `frames` table (what a writer keeps of a frame once its points are written)."""
    scan = frame.scan
    return {
        "frame": frame.index,
        "time_s": frame.time_s,
        "label_time_s": frame.label_time_s,
        "num_points": len(scan.points_m),
        "num_boxes": len(frame.labels.boxes),
        "shots": scan.shots,
        "dropped": scan.dropped,
        "missed": scan.missed,
    }


FRAME_ROW_TYPES = {"frame": np.int32, "time_s": np.float64, "label_time_s": np.float64, "num_points": np.int32,
                   "num_boxes": np.int32, "shots": np.int64, "dropped": np.int64, "missed": np.int64}


def frames_table(clip: str, rows: Sequence[dict]) -> pa.Table:
    """The `frames` table of a clip's `frame_row`s."""
    columns = {name: np.array([row[name] for row in rows], dtype) for name, dtype in FRAME_ROW_TYPES.items()}
    return _table("frames", {"clip": _clip_column(clip, len(rows)), **columns})


def points_table(frame: LabelledFrame) -> pa.Table:
    scan = frame.scan
    points = np.asarray(scan.points_m, np.float32)
    return _table(
        "points",
        {
            "clip": _clip_column(frame.clip, len(points)),
            "frame": np.full(len(points), frame.index, np.int32),
            "x": points[:, 0],
            "y": points[:, 1],
            "z": points[:, 2],
            "intensity": np.asarray(scan.intensity, np.uint8),
            "time_offset_s": np.asarray(scan.time_offset_s, np.float32),
            "sensor": np.asarray(scan.sensor, np.uint8),
            "head": np.asarray(scan.head, np.uint8),
            "sweep": np.asarray(scan.sweep, np.uint8),
            "line": np.asarray(scan.line, np.uint8),
            "instance_id": np.asarray(scan.instance_id, np.int32),
            "semantic": np.asarray(scan.semantic, np.uint8),
        },
    )


def boxes_table(clip: str, indices: Sequence[int], labels: Sequence[FrameLabels]) -> pa.Table:
    """The `boxes` table of a clip's frames `indices` with their labels."""
    boxes = np.concatenate([np.asarray(lab.boxes, np.float32).reshape(-1, 7) for lab in labels])
    frame_column = np.concatenate([np.full(len(lab.boxes), index, np.int32) for index, lab in zip(indices, labels)])
    columns = {
        "clip": _clip_column(clip, len(frame_column)),
        "frame": frame_column,
        "track_id": np.concatenate([np.asarray(lab.track_id, np.int32) for lab in labels]),
        "team": _categories([lab.team for lab in labels]),
        "role": _categories([lab.role for lab in labels]),
        **{name: boxes[:, i] for i, name in enumerate(BOX_FIELDS)},
        "velocity_mps": _fixed_list(np.concatenate([lab.velocity_mps for lab in labels]), 3),
        "keypoints_m": _fixed_list(np.concatenate([lab.keypoints_m for lab in labels]), NUM_KEYPOINTS * 3),
        "num_points": np.concatenate([np.asarray(lab.num_points, np.int32) for lab in labels]),
        "discontinuity": np.concatenate([np.asarray(lab.discontinuity, bool) for lab in labels]),
    }
    return _table("boxes", columns)


def sensors_table(sensors: Sequence[Sensor]) -> pa.Table:
    """The `sensors` table: each sensor's record (`Sensor.record`) as a row, its pose as six columns."""
    records = [s.record() for s in sensors]
    pose = np.array([r["pose"] for r in records], np.float64).reshape(-1, 6)
    columns = {name: [r[name] for r in records] for name in TABLES["sensors"].names if name not in SENSOR_POSE_COLUMNS}
    return _table("sensors", columns | {name: pose[:, i] for i, name in enumerate(SENSOR_POSE_COLUMNS)})


def table_writer(path: Path, name: str) -> pq.ParquetWriter:
    """A Parquet writer of table `name` with the fixed options that keep bytes reproducible."""
    schema = with_table_metadata(TABLES[name], name)
    floats = [f.name for f in schema if pa.types.is_floating(f.type)]  # byte-stream-split compresses them best
    others = [f.name for f in schema if f.name not in floats]
    return pq.ParquetWriter(
        path, schema, compression="zstd", use_byte_stream_split=floats, use_dictionary=others, write_statistics=True,
        write_page_checksum=True,
    )


class ParquetClipStream:
    """One clip's tables written as its frames come: `points` in row groups of
    `POINTS_FRAMES_PER_GROUP` frames, `frames` and `boxes` in row groups of `FRAMES_PER_GROUP` frames
    (only those frames' points and labels are kept meanwhile). Every file lives under a temporary name
    until `close`; `abort` (or an exception inside `with`) removes them, so a failure leaves no file
    under a final name."""

    TABLES = CLIP_TABLES

    def __init__(self, root: Path, clip: str):
        self.root, self.clip = Path(root), clip
        self._files = contextlib.ExitStack()
        self._writers: dict[str, pq.ParquetWriter] = {}
        self._tmp: dict[str, Path] = {}
        for name in self.TABLES:
            path = self.root / table_path(name, clip)
            path.parent.mkdir(parents=True, exist_ok=True)
            self._tmp[name] = self._files.enter_context(atomic_path(path))
        self._writers = {name: table_writer(self._tmp[name], name) for name in self.TABLES}
        self._rows = dict.fromkeys(self.TABLES, 0)
        self._frame_rows: list[dict] = []
        self._labels: list[tuple[int, FrameLabels]] = []
        self._points: list[pa.Table] = []

    def _write(self, name: str, table: pa.Table) -> None:
        self._writers[name].write_table(table, row_group_size=max(len(table), 1))
        self._rows[name] += len(table)

    def _flush_labels(self) -> None:
        if self._frame_rows:
            self._write("frames", frames_table(self.clip, self._frame_rows))
            self._write("boxes", boxes_table(self.clip, [i for i, _ in self._labels], [lab for _, lab in self._labels]))
            self._frame_rows, self._labels = [], []

    def _flush_points(self) -> None:
        if self._points:
            self._write("points", pa.concat_tables(self._points))
            self._points = []

    def add(self, frame: LabelledFrame) -> None:
        self._points.append(points_table(frame))
        if len(self._points) == POINTS_FRAMES_PER_GROUP:
            self._flush_points()
        self._frame_rows.append(frame_row(frame))
        self._labels.append((frame.index, frame.labels))
        if len(self._frame_rows) == FRAMES_PER_GROUP:
            self._flush_labels()

    def close(self) -> list[FileRecord]:
        """Finish every file, rename each to its final name; their records."""
        self._flush_points()
        self._flush_labels()
        for writer in self._writers.values():
            writer.close()
        self._files.close()
        return [record_file(self.root, table_path(name, self.clip), self._rows[name]) for name in self.TABLES]

    def abort(self) -> None:
        for writer in self._writers.values():
            with contextlib.suppress(Exception):
                writer.close()
        self._files.__exit__(RuntimeError, RuntimeError("aborted"), None)


def _column(table: pa.Table, name: str) -> NDArray:
    return table[name].to_numpy()


def _fixed(table: pa.Table, name: str, shape: tuple[int, ...]) -> NDArray[np.float32]:
    """A fixed-size list column as an (N, *shape) float32 array."""
    return table[name].combine_chunks().flatten().to_numpy().reshape(-1, *shape)


def _point_fields(points: pa.Table) -> dict[str, NDArray]:
    """A frame's `points` rows as the per-point fields `ScanFrame` and `Frame` share."""
    fields = {
        name: _column(points, name)
        for name in ("intensity", "time_offset_s", "sensor", "head", "instance_id", "semantic", "sweep", "line")
    }
    return {"points_m": np.stack([_column(points, axis) for axis in "xyz"], axis=1), **fields}


def _box_fields(boxes: pa.Table) -> dict[str, NDArray]:
    """A frame's `boxes` rows as the per-humanoid fields `FrameLabels` and `Frame` share."""
    return {
        "boxes": np.stack([_column(boxes, name) for name in BOX_FIELDS], axis=1).reshape(-1, 7),
        "track_id": _column(boxes, "track_id"),
        "team": np.array(boxes["team"].to_pylist(), dtype=np.str_),
        "role": np.array(boxes["role"].to_pylist(), dtype=np.str_),
        "velocity_mps": _fixed(boxes, "velocity_mps", (3,)),
        "keypoints_m": _fixed(boxes, "keypoints_m", (NUM_KEYPOINTS, 3)),
        "num_points": _column(boxes, "num_points"),
        "discontinuity": _column(boxes, "discontinuity"),
    }


def labelled_frames(root: Path, clip: str) -> Iterator[LabelledFrame]:
    """The frames a `ParquetClipStream` wrote under `root`, back as `LabelledFrame`s one at a time
    (partial clips of `simgen generate`'s shards): written again, they give the same bytes."""
    from simgen.labels.boxes import FrameLabels
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.render.frame import ScanFrame

    rows = open_table(root / table_path("frames", clip), "frames").read().to_pylist()
    points = open_table(root / table_path("points", clip), "points")
    boxes = open_table(root / table_path("boxes", clip), "boxes")
    for position, row in enumerate(rows):
        if position % FRAMES_PER_GROUP == 0:  # row groups of `boxes` hold FRAMES_PER_GROUP frames
            group, offset = boxes.read_row_group(position // FRAMES_PER_GROUP), 0
        box, offset = group.slice(offset, row["num_boxes"]), offset + row["num_boxes"]
        if position % POINTS_FRAMES_PER_GROUP == 0:
            point_group, point_offset = points.read_row_group(position // POINTS_FRAMES_PER_GROUP), 0
        point, point_offset = point_group.slice(point_offset, row["num_points"]), point_offset + row["num_points"]

        scan = ScanFrame(**_point_fields(point), shots=row["shots"], dropped=row["dropped"], missed=row["missed"])
        labels = FrameLabels(**_box_fields(box))
        yield LabelledFrame(clip, row["frame"], row["time_s"], row["label_time_s"], scan, labels)


def _write_dataset_table(root: Path, relative: str, table: pa.Table) -> FileRecord:
    (root / relative).parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(root / relative) as tmp, table_writer(tmp, relative.split("/", 1)[0]) as writer:
        writer.write_table(table, row_group_size=max(len(table), 1))
    return record_file(root, relative, len(table))


def write_parquet_sensors(root: Path, sensors: Sequence[Sensor]) -> FileRecord:
    """The dataset's one `sensors` table."""
    return _write_dataset_table(root, SENSORS_PATH, sensors_table(sorted(sensors, key=lambda s: s.sensor_id)))


def write_parquet_units(root: Path) -> FileRecord:
    """The dataset's one `units` table: every column's unit and meaning, as rows."""
    return _write_dataset_table(root, UNITS_PATH, _table("units", units_rows()))


def open_table(path: Path, name: str) -> pq.ParquetFile:
    """Open one of our Parquet files; another schema version or table is a one-line `UserError`."""
    try:
        parquet = pq.ParquetFile(path, page_checksum_verification=True)
    except (OSError, pa.ArrowException) as error:
        raise UserError(f"{path}: not a readable Parquet file ({error})") from None
    raw = (parquet.schema_arrow.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise UserError(f"{path}: not a simgen dataset table (no {METADATA_KEY.decode()} metadata)")
    try:
        metadata = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise UserError(f"{path}: malformed {METADATA_KEY.decode()} metadata") from None
    if not isinstance(metadata, dict):
        raise UserError(f"{path}: malformed {METADATA_KEY.decode()} metadata")
    if metadata.get("schema_version") != SCHEMA_VERSION:
        raise UserError(
            f"{path}: dataset schema version {metadata.get('schema_version')}, this simgen reads {SCHEMA_VERSION}"
        )
    if metadata.get("table") != name or not parquet.schema_arrow.equals(TABLES[name], check_metadata=False):
        raise UserError(f"{path}: not the {name} table of schema version {SCHEMA_VERSION}")
    return parquet


@dataclass(frozen=True)
class _ClipTables:
    frames: pa.Table
    boxes: pq.ParquetFile  # read a row group (FRAMES_PER_GROUP frames) at a time: memory flat in a clip's length
    box_offsets: NDArray[np.int64]  # (F + 1,) first box row of each frame
    points: pq.ParquetFile
    point_offsets: NDArray[np.int64]  # (F + 1,) first point row of each frame in the clip


class ParquetReader:
    """Frames of a Parquet dataset whose frames hold at most `most_points` points (`limits.max_points_per_frame`)."""

    def __init__(self, files: DatasetFiles, most_points: int):
        self.files = files
        self.most_points = most_points
        self._clip = functools.lru_cache(maxsize=OPEN_CLIPS)(self._load_clip)
        self._last: dict[str, tuple[tuple[str, int], pa.Table]] = {}  # table name -> its last row group read

    def _open(self, name: str, clip: str) -> pq.ParquetFile:
        """The table, its declared rows and bytes checked (nothing read yet)."""
        relative = table_path(name, clip)
        parquet = open_table(self.files.path(relative), name)
        rows = self.files.rows(relative)
        if name == "boxes":
            limit = (FRAMES_PER_GROUP * MAX_BOXES_PER_FRAME, "a match's humanoids fill")
        else:
            limit = ({"frames": FRAMES_PER_GROUP, "points": POINTS_FRAMES_PER_GROUP * self.most_points}.get(name, rows),
                     "fit the dataset's sensors")
        check_declared_sizes(parquet, self.files.root / relative, rows, *limit)
        return parquet

    def _read(self, name: str, clip: str) -> pa.Table:
        try:
            return self._open(name, clip).read()
        except (OSError, pa.ArrowException) as error:
            raise UserError(f"{self.files.root / table_path(name, clip)}: unreadable ({error})") from None

    def _load_clip(self, clip: str) -> _ClipTables:
        frames = self._read("frames", clip)  # as many rows as manifest.json lists: `_open` checks it
        count = len(frames)
        counts, box_counts = frames["num_points"].to_numpy(), frames["num_boxes"].to_numpy()
        frames_path = self.files.root / table_path("frames", clip)
        if count:  # before any of the points or boxes is read
            worst = int(np.argmax(counts))
            check_points(frames_path, f"frame {worst}", int(counts[worst]), 1, self.most_points)
            worst = int(np.argmax(box_counts))
            check_boxes(frames_path, f"frame {worst}", int(box_counts[worst]), 1)
        boxes_path = table_path("boxes", clip)
        check_boxes(self.files.root / boxes_path, "the table", self.files.rows(boxes_path), count)
        boxes = self._open("boxes", clip)
        try:
            box_index = boxes.read(columns=["clip", "frame"])
        except (OSError, pa.ArrowException) as error:
            raise UserError(f"{self.files.root / table_path('boxes', clip)}: unreadable ({error})") from None
        points = self._open("points", clip)
        path = self.files.root / table_path("points", clip)
        groups = -(-count // POINTS_FRAMES_PER_GROUP)
        if points.metadata.num_row_groups != groups or not np.array_equal(frames["frame"].to_numpy(), np.arange(count)):
            raise UserError(f"{path}: row groups do not match the clip's {count} frames")
        for name, table in (("frames", frames), ("boxes", box_index)):
            if set(table["clip"].unique().to_pylist()) - {clip}:
                raise UserError(f"{self.files.root / table_path(name, clip)}: rows of another clip than {clip}")
        offsets = np.searchsorted(box_index["frame"].to_numpy(), np.arange(count + 1))
        if not np.array_equal(np.diff(offsets), box_counts):
            raise UserError(f"{self.files.root / table_path('boxes', clip)}: rows are not the boxes the frames table "
                            "counts")
        box_groups = [boxes.metadata.row_group(g).num_rows for g in range(boxes.metadata.num_row_groups)]
        box_starts = offsets[np.minimum(np.arange(-(-count // FRAMES_PER_GROUP) + 1) * FRAMES_PER_GROUP, count)]
        if box_groups != np.diff(box_starts).tolist():
            raise UserError(f"{self.files.root / table_path('boxes', clip)}: row groups do not hold "
                            f"{FRAMES_PER_GROUP} frames each")
        sizes = [points.metadata.row_group(g).num_rows for g in range(groups)]
        point_offsets = np.concatenate([[0], np.cumsum(frames["num_points"].to_numpy(), dtype=np.int64)])
        group_starts = point_offsets[np.minimum(np.arange(groups + 1) * POINTS_FRAMES_PER_GROUP, count)]
        if sizes != np.diff(group_starts).tolist():
            raise UserError(f"{path}: row groups do not hold the points the frames table counts")
        return _ClipTables(frames, boxes, offsets, points, point_offsets)

    def _group(self, name: str, clip: str, group: int) -> pa.Table:
        """Row group `group` of a clip's `points` or `boxes`; the last one read of each is kept (frames are mostly
        read in order)."""
        key, table = self._last.get(name, (None, None))
        if key != (clip, group):
            try:
                table = getattr(self._clip(clip), name).read_row_group(group)
            except (OSError, pa.ArrowException) as error:
                raise UserError(
                    f"{self.files.root / table_path(name, clip)}: unreadable row group {group} ({error})"
                ) from None
            self._last[name] = ((clip, group), table)
        return table

    def frame(self, clip: str, index: int) -> Frame:
        tables = self._clip(clip)
        group = index // POINTS_FRAMES_PER_GROUP
        first = tables.point_offsets[group * POINTS_FRAMES_PER_GROUP]
        points = self._group("points", clip, group).slice(
            tables.point_offsets[index] - first, tables.point_offsets[index + 1] - tables.point_offsets[index]
        )
        point_frame = points["frame"]
        if len(point_frame) and not point_frame[0].as_py() == point_frame[-1].as_py() == index:
            raise UserError(
                f"{self.files.root / table_path('points', clip)}: frame {index}'s points are not where the frames "
                "table counts them"
            )
        box_group = index // FRAMES_PER_GROUP
        boxes = self._group("boxes", clip, box_group).slice(
            tables.box_offsets[index] - tables.box_offsets[box_group * FRAMES_PER_GROUP],
            tables.box_offsets[index + 1] - tables.box_offsets[index],
        )
        frame_row = tables.frames.slice(index, 1).to_pylist()[0]
        box_fields = _box_fields(boxes)
        return Frame(
            clip=clip,
            index=index,
            class_name=class_names(box_fields["team"]),
            time_s=frame_row["time_s"],
            label_time_s=frame_row["label_time_s"],
            **_point_fields(points),
            **box_fields,
        )


COUNTS = ("num_points", "shots", "dropped", "missed")  # the frames table's columns `frame_counts` gives


def _schema_rows(schema: pa.Schema) -> list[list]:
    def meta(field: pa.Field, key: bytes) -> str:
        return (field.metadata or {}).get(key, b"").decode()

    def kind(type_: pa.DataType) -> str:
        return f"{type_.value_type} (dictionary)" if pa.types.is_dictionary(type_) else str(type_)

    return [[f"`{f.name}`", f"`{kind(f.type)}`", meta(f, b"unit") or "-", meta(f, b"doc")] for f in schema]


class Parquet(DatasetFormat):
    name = "parquet"
    carries = Carries(track_ids=True, point_fields=True, point_counts=True, units=True)
    packable = True

    def stream(self, root, clip, clip_index, sensors):
        return ParquetClipStream(root, clip)

    def reader(self, files, manifest):
        return ParquetReader(files, max_points_per_frame(manifest.sensors))

    def clip_files(self, entry: ClipEntry) -> set[str]:
        return {table_path(name, entry.clip) for name in CLIP_TABLES}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        return {SENSORS_PATH, UNITS_PATH}

    def finish(self, root: Path, clips: Sequence[ClipRecord], sensors, scenario: Mapping) -> list[FileRecord]:
        return [write_parquet_sensors(root, sensors), write_parquet_units(root)]

    def listed_rows_problem(self, entry: ClipEntry, listed: Mapping[str, FileRecord], sensors: int) -> str | None:
        rows = listed[table_path("frames", entry.clip)].rows
        return (
            None if rows == entry.frames else f"clip {entry.clip} lists {entry.frames} frames, its frames table {rows}"
        )

    def card_layout(self, manifest: Manifest) -> list[str]:
        lines = [
            "Apache Parquet, zstd, laid out like Waymo Open Dataset v2: one table per component, a file per clip",
            "(`<table>/<clip id>/part-0.parquet`) whose rows carry their keys `clip` and `frame` inside the file (so a",
            "file copied out of its folder still says what it holds), and `sensors/part-0.parquet` once per dataset.",
            "`points` row groups hold 10 whole frames (group g: frames 10 g .. 10 g + 9); "
            "`frames` and `boxes` row groups",
            "hold whole frames. Units and meanings are in each field's metadata (`unit`, `doc`), "
            "which only pyarrow shows,",
            "and, for duckdb, polars and pandas, as rows of the `units` table "
            "(`units/part-0.parquet`, once per dataset):",
            "`duckdb -c \"select * from 'units/*.parquet' where table_name = 'points'\"`.",
        ]
        for name, schema in TABLES.items():
            rows = _schema_rows(schema)
            lines += ["", f"### `{name}`", "", *markdown.table(["column", "type", "unit", "meaning"], rows)]
        return lines

    def card_loading(self) -> list[str]:
        return [
            "",
            "As is, with the usual tools:",
            "",
            "```python",
            "import pandas as pd; points = pd.read_parquet('points')            # clip and frame are columns",
            "import polars as pl; boxes = pl.read_parquet('boxes/**/*.parquet')",
            "import pyarrow.dataset as ds; frames = ds.dataset('frames').to_table()",
            "```",
            "",
            "```sh",
            "duckdb -c \"select clip, frame, count(*) from 'points/**/*.parquet' group by all order by all\"",
            "duckdb -c \"select column_name, unit, doc from 'units/*.parquet' where table_name = 'boxes'\"",
            "```",
            "",
            "(`duckdb` is the `duckdb-cli` package, on the PATH of simgen's `.venv`.)",
        ]

    def summary_lines(self, output: str) -> list[str]:
        return [f"          duckdb -c \"select count(*) from '{output}/points/**/*.parquet'\""]

    def file_problem(self, path: Path, relative: str) -> str | None:
        name = relative.split("/", 1)[0]
        if name not in TABLES:
            return None
        try:
            open_table(path, name)
        except UserError as error:
            return str(error).removeprefix(f"{path}: ")
        return None

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        boxes = str(root / table_path("boxes", entry.clip))
        return lambda k, i: (boxes, first_row[k] + i)  # row index, from 0

    def clip_problems(self, files: DatasetFiles, entry: ClipEntry, sizes: Sequence[tuple[int, int]]) -> list[Problem]:
        """The `frames` table against the frames' (points, boxes), and every shot accounted for."""
        path = str(files.root / table_path("frames", entry.clip))
        frames = open_table(files.path(table_path("frames", entry.clip)), "frames").read().to_pydict()
        problems = []
        for row, (points, boxes) in enumerate(sizes):
            stored = {name: frames[name][row] for name in ("num_points", "num_boxes", "shots", "dropped", "missed")}
            if stored["num_points"] != points:
                problems.append(
                    Problem(path, row, f"num_points is {stored['num_points']}, the frame has {points} points")
                )
            if stored["num_boxes"] != boxes:
                problems.append(Problem(path, row, f"num_boxes is {stored['num_boxes']}, the frame has {boxes} boxes"))
            returns = stored["shots"] - stored["dropped"] - stored["missed"]
            if returns != stored["num_points"]:
                problems.append(
                    Problem(path, row, f"shots - dropped - missed = {returns}, num_points is {stored['num_points']}")
                )
        return problems

    def frame_counts(self, files: DatasetFiles, clips: Sequence[str]) -> dict[str, np.ndarray]:
        tables = [open_table(files.path(table_path("frames", clip)), "frames").read() for clip in clips]
        return {name: np.concatenate([t[name].to_numpy() for t in tables]).astype(np.int64) for name in COUNTS}


FORMAT = Parquet()
