"""A Parquet dataset's compact copy, for carrying it to a training machine, and back to a dataset.

`pack` copies every file byte for byte except the `points` tables, whose x, y, z become whole
millimetres (int32, delta-coded, zstd level 19): paper_x1 goes from 157 to 61 MB. `unpack` writes
those points back as float32 metres in the reader's layout (same row groups, writer options and
metadata) and a manifest with the new files' sizes and sha256, so the result opens and verifies like
any dataset. Rounding to 1 mm moves a point by at most 0.5 mm, far inside the scenarios' default 2 cm
range noise (`noise.range_sigma_m`); intensity, times, ids and every label table are unchanged.
`unpack` checks what it copies: the unchanged files against their sha256, the points tables' page
checksums and row counts.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from tqdm import tqdm

from simgen.atomic import atomic_path
from simgen.datasets.card import dataset_card
from simgen.datasets.formats import dataset_format
from simgen.datasets.formats.parquet import POINTS_FRAMES_PER_GROUP, table_writer
from simgen.datasets.limits import check_declared_sizes, max_points_per_frame
from simgen.datasets.manifest import MANIFEST_NAME, Manifest, manifest_bytes, read_manifest
from simgen.datasets.records import FileRecord, record_file, sha256_file, write_bytes
from simgen.datasets.schema import TABLES
from simgen.datasets.write import CARD_NAME, write_card
from simgen.errors import UserError

COORDINATES = ("x", "y", "z")
MM_PER_M = 1000
PACKED_NAME = "packed.json"  # a packed copy's manifest (the original's); `open_dataset` refuses the copy


def pack(dataset: Path, out: Path, progress: bool = False) -> Manifest:
    """Copy the Parquet dataset `dataset` into `out` (created) with its points in whole millimetres.

    Every file is checked against the manifest's sha256 first; a link (file or folder) is refused, never followed.
    """
    manifest = read_manifest(dataset)
    if not dataset_format(manifest.format).packable:
        raise UserError(f"{dataset}: pack reads Parquet datasets, this one is {manifest.format}")
    most = max_points_per_frame(manifest.sensors)
    sources = _sources(dataset, manifest, MANIFEST_NAME, most)
    with _staging(out) as staging:
        for record, source in tqdm(zip(manifest.files, sources), desc=f"pack {out.name}", unit="file", leave=False,
                                   total=len(sources), disable=not progress):
            target = staging / record.path
            if sha256_file(source) != record.sha256:
                raise UserError(f"{source}: sha256 differs from {MANIFEST_NAME} (corrupt or modified)")
            target.parent.mkdir(parents=True, exist_ok=True)
            if _is_points(record):
                _millimetres(source, target, record.rows, most)
            else:
                shutil.copyfile(source, target)
        write_card(staging, manifest)
        write_bytes(staging, PACKED_NAME, manifest_bytes(manifest), len(manifest.files))
    return manifest


def unpack(packed: Path, out: Path, progress: bool = False) -> Manifest:
    """Write the dataset that `pack` put in `packed` into `out` (created), points in float32 metres.

    Every file, README.md included, is checked against packed.json (sha256, or for the points tables their declared
    sizes, page checksums and rows) before it is expanded; a link (file or folder) is refused, never followed.
    """
    _source(packed, PACKED_NAME, PACKED_NAME, "not a dataset that `simgen pack` wrote")
    manifest = read_manifest(packed, PACKED_NAME)
    card = dataset_card(manifest).encode()
    if (packed / CARD_NAME).exists() or (packed / CARD_NAME).is_symlink():
        if _source(packed, CARD_NAME, PACKED_NAME).read_bytes() != card:
            raise UserError(f"{packed / CARD_NAME}: differs from the dataset card {PACKED_NAME} gives (modified?)")
    most = max_points_per_frame(manifest.sensors)
    sources = _sources(packed, manifest, PACKED_NAME, most)
    with _staging(out) as staging:
        records = []
        for record, source in tqdm(zip(manifest.files, sources), desc=f"unpack {out.name}", unit="file", leave=False,
                                   total=len(sources), disable=not progress):
            target = staging / record.path
            target.parent.mkdir(parents=True, exist_ok=True)
            if _is_points(record):
                _metres(source, target, record.rows, most)
                record = record_file(staging, record.path, record.rows)
            else:
                if sha256_file(source) != record.sha256:
                    raise UserError(f"{source}: sha256 differs from {PACKED_NAME} (damaged on the way?)")
                shutil.copyfile(source, target)
            records.append(record)
        write_bytes(staging, CARD_NAME, card, 0)
        manifest = replace(manifest, files=tuple(records))
        write_bytes(staging, MANIFEST_NAME, manifest_bytes(manifest), len(records))
    return manifest


def _sources(root: Path, manifest: Manifest, listed_in: str, most_points: int) -> list[Path]:
    """Every listed file of `root` (`_source`), the points tables' declared sizes checked: all before any is read."""
    sources = [_source(root, record.path, listed_in) for record in manifest.files]
    for record, source in zip(manifest.files, sources):
        if _is_points(record):
            with _points_table(source, record.rows, most_points):
                pass
    return sources


def _source(root: Path, relative: str, listed_in: str, missing: str | None = None) -> Path:
    """`root / relative`, a regular file reached through no link (checked component by component)."""
    path = root
    for part in relative.split("/"):
        path = path / part
        try:
            mode = path.lstat().st_mode
        except FileNotFoundError:
            raise UserError(
                f"{root}: no {relative}, {missing}" if missing else f"{path}: missing ({listed_in} lists it)"
            ) from None
        if stat.S_ISLNK(mode):
            raise UserError(f"{path}: a link; pack and unpack copy no links (to {os.readlink(path)})")
    if not stat.S_ISREG(mode):
        raise UserError(f"{path}: not a regular file")
    return path


def _is_points(record: FileRecord) -> bool:
    return record.path.startswith("points/")


class _staging:
    """A fresh folder beside `out`, renamed to `out` on success and removed on failure: no half-written `out`."""

    def __init__(self, out: Path):
        if out.exists():
            raise UserError(f"{out}: already exists")
        self.out, self.path = out, out.parent / f".{out.name}.partial"

    def __enter__(self) -> Path:
        shutil.rmtree(self.path, ignore_errors=True)
        self.path.mkdir(parents=True)
        return self.path

    def __exit__(self, kind, error, trace) -> None:
        if kind is None:
            self.path.rename(self.out)
        else:
            shutil.rmtree(self.path, ignore_errors=True)


@contextlib.contextmanager
def _points_table(path: Path, rows: int, most_points: int):
    """Yields `path`'s row groups (page checksums verified), their declared rows and bytes checked first (`rows` in
    all, at most `most_points` a frame); a missing, unreadable or foreign points table is a one-line `UserError`
    (the disk's own errors, which carry an errno, pass through)."""
    try:
        source = pq.ParquetFile(path, page_checksum_verification=True)
        check_declared_sizes(source, path, rows, POINTS_FRAMES_PER_GROUP * most_points)
        yield (source.read_row_group(group) for group in range(source.num_row_groups))
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError, KeyError, OSError) as error:
        if isinstance(error, OSError) and error.errno is not None:
            raise
        said = " ".join(str(error).splitlines())[:160]
        raise UserError(f"{path}: not a readable points table ({error.__class__.__name__}: {said})") from None


def _millimetres(source: Path, target: Path, rows: int, most_points: int) -> None:
    """A points table with x, y, z in whole millimetres (int32)."""
    with _points_table(source, rows, most_points) as groups:
        schema = pa.schema([pa.field(f.name, pa.int32()) if f.name in COORDINATES else f for f in TABLES["points"]])
        floats = [f.name for f in schema if pa.types.is_floating(f.type)]
        encodings = dict.fromkeys(COORDINATES, "DELTA_BINARY_PACKED") | dict.fromkeys(floats, "BYTE_STREAM_SPLIT")
        with atomic_path(target) as tmp, pq.ParquetWriter(
            tmp, schema, compression="zstd", compression_level=19, use_dictionary=False, column_encoding=encodings,
            write_page_checksum=True,
        ) as writer:
            for table in groups:
                for c in COORDINATES:
                    millimetres = np.rint(table[c].to_numpy().astype(np.float64) * MM_PER_M).astype(np.int32)
                    table = table.set_column(table.schema.get_field_index(c), schema.field(c), pa.array(millimetres))
                writer.write_table(table.cast(schema), row_group_size=max(len(table), 1))


def _metres(source: Path, target: Path, rows: int, most_points: int) -> None:
    """The reader's points table back from `_millimetres`'s: x, y, z in float32 metres."""
    written = 0
    with (
        _points_table(source, rows, most_points) as groups,
        atomic_path(target) as tmp,
        table_writer(tmp, "points") as writer,
    ):
        for table in groups:
            for c in COORDINATES:
                metres = (table[c].to_numpy() / np.float64(MM_PER_M)).astype(np.float32)
                table = table.set_column(table.schema.get_field_index(c), c, pa.array(metres))
            writer.write_table(table.cast(writer.schema), row_group_size=max(len(table), 1))
            written += len(table)
    if written != rows:
        raise UserError(f"{source}: {written} points, {PACKED_NAME} says {rows}")
