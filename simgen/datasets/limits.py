"""What a dataset may hold, checked against what its files declare before anything is expanded.

A shot gives at most one point, so a frame holds at most what its sensors fire in one frame time; a box is a
humanoid, so a frame holds at most the engine's 25 (`MAX_BOXES_PER_FRAME`). A dataset that declares more (in
manifest.json, a `frames` table, a Parquet row group or a label file's lines) is refused in one line before a
reader, `verify`, `pack` or `unpack` allocates for it: a few MB of zeros declaring 3 million points a frame
cannot take a reader past 1 GiB.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from simgen.errors import UserError
from simgen.scan.sensor import Sensor
from simgen.scenario import BYTES_PER_RAY, BYTES_PER_SHOT, MAX_FRAME_BYTES
from simgen.vocab import MAX_HUMANOIDS

#: Points a frame of any scenario may hold: its shots within the frame memory budget at one subray.
MAX_POINTS_PER_FRAME = MAX_FRAME_BYTES // (BYTES_PER_SHOT + BYTES_PER_RAY)
#: Boxes a frame may hold: one per humanoid on the pitch (the ball has none).
MAX_BOXES_PER_FRAME = MAX_HUMANOIDS
#: Bytes a row's values take uncompressed, by column type (a dictionary column's index; strings at most this).
MAX_STRING_BYTES = 1024
#: Allowance per Parquet row group beyond its values: dictionary pages, levels, page headers.
ROW_GROUP_OVERHEAD_BYTES = 1 << 20


def max_points_per_frame(sensors: Sequence[Sensor]) -> int:
    """The most points a frame of these sensors can hold: per sensor its shots in one frame time (its recorded
    rate, at most its preset's at its density) and one more per head for the window's ends; at most
    `MAX_POINTS_PER_FRAME`."""
    shots = 0
    for sensor in sensors:
        rate = min(sensor.shots_per_s, sum(h.shots_per_s for h in sensor.heads) * sensor.density)
        shots += math.ceil(rate / sensor.frame_rate_hz) + len(sensor.heads)
    return min(shots, MAX_POINTS_PER_FRAME)


def row_bytes(schema: pa.Schema) -> int:
    """Upper bound on one row's values of `schema` uncompressed, bytes (strings at most `MAX_STRING_BYTES`)."""
    total = 0
    for field in schema:
        kind = field.type
        if pa.types.is_dictionary(kind):
            kind = kind.index_type
        width = kind.list_size * kind.value_type.bit_width if pa.types.is_fixed_size_list(kind) else None
        if width is None:
            width = (
                kind.bit_width if not (pa.types.is_string(kind) or pa.types.is_binary(kind)) else 8 * MAX_STRING_BYTES
            )
        total += max(width, 8) // 8 + 1  # + a definition level
    return total


def check_declared_sizes(
    parquet: pq.ParquetFile, path: Path, rows: int, most_rows_per_group: int, why: str = "fit the dataset's sensors"
) -> None:
    """Before reading `parquet`: it holds `rows` rows (as the manifest lists), no row group more than
    `most_rows_per_group` (the limit `why`), and no row group declares more bytes than its rows' values can take."""
    metadata = parquet.metadata
    if metadata.num_rows != rows:
        raise UserError(f"{path}: declares {metadata.num_rows:,} rows, manifest.json lists {rows:,}")
    per_row = row_bytes(parquet.schema_arrow)
    for group in range(metadata.num_row_groups):
        declared = metadata.row_group(group)
        if declared.num_rows > most_rows_per_group:
            raise UserError(f"{path}: row group {group} declares {declared.num_rows:,} rows, at most "
                            f"{most_rows_per_group:,} {why}")
        size = sum(declared.column(c).total_uncompressed_size for c in range(declared.num_columns))
        if size > declared.num_rows * per_row + ROW_GROUP_OVERHEAD_BYTES:
            raise UserError(f"{path}: row group {group} declares {size:,} bytes for {declared.num_rows:,} rows, "
                            f"more than {per_row} a row")


def check_points(where: Path, what: str, points: int, frames: int, most: int) -> None:
    """`points` declared for `what` (a clip, a frame) in `frames` frames fit `most` a frame (`max_points_per_frame`)."""
    if points > frames * most:
        raise UserError(f"{where}: {what} declares {points:,} points in {frames:,} frame{'s' * (frames != 1)}, more "
                        f"than its sensors fire (at most {most:,} a frame)")


def check_boxes(where: Path, what: str, boxes: int, frames: int) -> None:
    """`boxes` declared for `what` (a clip, a frame) in `frames` frames fit `MAX_BOXES_PER_FRAME` a frame."""
    if boxes > frames * MAX_BOXES_PER_FRAME:
        raise UserError(f"{where}: {what} declares {boxes:,} boxes in {frames:,} frame{'s' * (frames != 1)}, more "
                        f"than a match has humanoids (at most {MAX_BOXES_PER_FRAME} a frame)")


def check_label_lines(path: Path, text: str, frames: int) -> None:
    """A label text file (a line a box, as simgen writes them) of `frames` frames holds no more lines than their boxes
    may be, counted before any line is split."""
    check_boxes(path, "the file", text.count("\n") + bool(text and not text.endswith("\n")), frames)
