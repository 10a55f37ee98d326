"""The `parquet` format (the default): a file per clip and table, laid out like Waymo Open Dataset v2
(`simgen.datasets.parquet`); the only format that keeps every shot's bookkeeping and each box's points."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa

from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.limits import max_points_per_frame
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.markdown import table
from simgen.datasets.parquet import (
    SENSORS_PATH,
    UNITS_PATH,
    ParquetClipStream,
    ParquetReader,
    open_table,
    table_path,
    write_parquet_sensors,
    write_parquet_units,
)
from simgen.datasets.records import ClipRecord, FileRecord
from simgen.datasets.schema import CLIP_TABLES, TABLES
from simgen.datasets.verify import DatasetFiles, Problem
from simgen.errors import UserError

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
            lines += ["", f"### `{name}`", "", *table(["column", "type", "unit", "meaning"], _schema_rows(schema))]
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
