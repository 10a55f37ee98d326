"""The Parquet dataset as other tools see it: pyarrow.dataset, pandas, polars and duckdb read it as is."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import duckdb
import numpy as np
import pandas as pd
import polars as pl
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

import simgen.datasets
from simgen.datasets.manifest import MANIFEST_NAME
from simgen.datasets.records import sha256_file
from simgen.datasets.schema import CLIP_TABLES, METADATA_KEY, SCHEMA_VERSION, TABLES
from simgen.errors import UserError
from simgen.labels.labelled_frame import LabelledFrame
from tests.support.datasets import sample_clips, sensors, write_dataset

CLIPS = sample_clips()
POINTS = sum(len(f.scan.points_m) for frames in CLIPS for f in frames)
BOXES = sum(len(f.labels.boxes) for frames in CLIPS for f in frames)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    root = tmp_path_factory.mktemp("parquet")
    write_dataset(root, "parquet", CLIPS)
    return root


def test_duckdb_counts_the_points(root):
    assert duckdb.sql(f"select count(*) from '{root}/points/**/*.parquet'").fetchall() == [(POINTS,)]
    per_clip = duckdb.sql(
        f"select clip, count(*) from '{root}/boxes/**/*.parquet' group by clip order by clip"
    ).fetchall()
    assert per_clip == [(frames[0].clip, sum(len(f.labels.boxes) for f in frames)) for frames in CLIPS]


def test_the_duckdb_command_line_counts_the_points(root):
    duckdb_cli = Path(sys.executable).parent / "duckdb"  # the duckdb-cli package of the test extra
    query = f"select count(*) from '{root}/points/**/*.parquet'"
    command = [duckdb_cli, "-csv", "-noheader", "-c", query]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60, check=True)
    assert int(result.stdout) == POINTS


def test_pandas_polars_and_pyarrow_read_every_table(root):
    assert len(pd.read_parquet(root / "points")) == POINTS
    assert pl.scan_parquet(f"{root}/points/**/*.parquet").select(pl.len()).collect().item() == POINTS
    points = ds.dataset(root / "points").to_table()
    assert points.num_rows == POINTS and "clip" in points.column_names
    assert len(pd.read_parquet(root / "boxes")) == BOXES
    assert pl.read_parquet(f"{root}/frames/**/*.parquet").height == sum(map(len, CLIPS))
    assert ds.dataset(root / "sensors").to_table().num_rows == len(sensors())  # once per dataset, not per clip
    assert [p.relative_to(root).as_posix() for p in (root / "sensors").rglob("*.parquet")] == ["sensors/part-0.parquet"]


def test_duckdb_polars_and_pandas_find_every_columns_unit_in_the_units_table(root):
    """They drop Parquet field metadata, so the units are rows they read, listed in the manifest and the card."""
    want = {(name, f.name): (f.metadata[b"unit"].decode(), f.metadata[b"doc"].decode())
            for name in ("frames", "points", "boxes", "sensors") for f in TABLES[name]}
    rows = duckdb.sql(f"select table_name, column_name, unit, doc from '{root}/units/*.parquet'").fetchall()
    assert len(rows) == len(want) and {(t, c): (u, d) for t, c, u, d in rows} == want
    assert {(t, c): u for t, c, u, _ in rows}[("points", "time_offset_s")] == "s"
    assert pl.read_parquet(f"{root}/units/*.parquet").filter(pl.col("table_name") == "boxes").height == len(
        TABLES["boxes"]
    )
    assert (
        pd.read_parquet(root / "units").set_index(["table_name", "column_name"]).loc[("boxes", "yaw"), "unit"] == "rad"
    )
    listed = [f["path"] for f in json.loads((root / MANIFEST_NAME).read_text())["files"]]
    assert "units/part-0.parquet" in listed
    assert (
        "`duckdb -c \"select * from 'units/*.parquet' where table_name = 'points'\"`"
        in (root / "README.md").read_text()
    )


def test_every_file_carries_its_clip_and_frame(root, tmp_path):
    """A file copied out of its folder still says which clip and frames it holds (Waymo v2's key columns)."""
    for frames in CLIPS:
        clip = frames[0].clip
        for table in CLIP_TABLES:
            alone = tmp_path / f"{table}_{clip}.parquet"
            alone.write_bytes((root / table / clip / "part-0.parquet").read_bytes())
            keys = pq.read_table(alone, columns=["clip", "frame"]).to_pandas()
            assert set(keys["clip"]) <= {clip}
            expected = {
                "frames": [f.index for f in frames],
                "points": [f.index for f in frames for _ in range(len(f.scan.points_m))],
                "boxes": [f.index for f in frames for _ in range(len(f.labels.boxes))],
            }[table]
            assert keys["frame"].tolist() == expected and len(keys) == len(expected)
    per_clip = duckdb.sql(
        f"select clip, count(distinct frame) from '{root}/frames/*/*.parquet' group by clip order by clip"
    ).fetchall()
    assert per_clip == [(frames[0].clip, len(frames)) for frames in CLIPS]


def test_points_have_row_groups_of_ten_frames_and_documented_fields(root):
    for frames in CLIPS:
        parquet = pq.ParquetFile(root / f"points/{frames[0].clip}/part-0.parquet")
        groups = [parquet.metadata.row_group(i).num_rows for i in range(parquet.metadata.num_row_groups)]
        assert groups == [sum(len(f.scan.points_m) for f in frames[g : g + 10]) for g in range(0, len(frames), 10)]
        assert parquet.metadata.row_group(0).column(1).compression == "ZSTD"
    for name, schema in TABLES.items():
        for field in schema:
            assert field.metadata[b"doc"], (name, field.name)
    assert TABLES["points"].field("x").metadata[b"unit"] == b"m"
    keypoints = pd.read_parquet(root / "boxes")["keypoints_m"].iloc[0]
    np.testing.assert_array_equal(keypoints, CLIPS[0][0].labels.keypoints_m[0].reshape(-1))


def test_a_table_of_another_schema_version_is_rejected(tmp_path):
    write_dataset(tmp_path, "parquet", CLIPS[:1])
    relative = "frames/clip_0000/part-0.parquet"
    table = pq.read_table(tmp_path / relative, partitioning=None)
    metadata = json.loads(table.schema.metadata[METADATA_KEY])
    foreign = table.replace_schema_metadata({METADATA_KEY: json.dumps({**metadata, "schema_version": 99})})
    pq.write_table(foreign, tmp_path / relative)
    manifest = json.loads((tmp_path / MANIFEST_NAME).read_text())
    for entry in manifest["files"]:
        if entry["path"] == relative:
            entry.update(bytes=(tmp_path / relative).stat().st_size, sha256=sha256_file(tmp_path / relative))
    (tmp_path / MANIFEST_NAME).write_text(json.dumps(manifest))
    with pytest.raises(
        UserError, match=rf"part-0.parquet: dataset schema version 99, this simgen reads {SCHEMA_VERSION}$"
    ):
        simgen.datasets.open(tmp_path).frame("clip_0000", 0)


def test_partial_clips_read_back_and_rewritten_give_the_same_bytes(tmp_path, monkeypatch):
    """What `simgen generate` does with a clip's shards: each shard streams its frame range into a
    partial clip; the partial clips, read back in order, stream into the final files, whose bytes
    must be those of the clip written in one go (row groups of frames and boxes spanning shards)."""
    from simgen.datasets.formats import parquet
    from simgen.datasets.formats.parquet import labelled_frames
    from simgen.datasets.write import ClipWriter, write_clip
    from tests.support.datasets import make_clip, sensors

    monkeypatch.setattr(parquet, "FRAMES_PER_GROUP", 4)  # groups of frames and boxes cross the shards
    monkeypatch.setattr(parquet, "POINTS_FRAMES_PER_GROUP", 2)  # and so do groups of points
    frames = make_clip("clip_0000", 11, points=50, seed=3)
    whole = write_clip(tmp_path / "whole", "parquet", frames, sensors(), 0)
    for first, stop in ((0, 3), (3, 10), (10, 11)):
        with ClipWriter(tmp_path / f"shard{first}", "parquet", "clip_0000", 0, sensors(), first) as writer:
            for frame in frames[first:stop]:
                writer.add(frame)
            writer.close()
    with ClipWriter(tmp_path / "joined", "parquet", "clip_0000", 0, sensors()) as writer:
        for first in (0, 3, 10):
            for frame in labelled_frames(tmp_path / f"shard{first}", "clip_0000"):
                writer.add(frame)
        joined = writer.close()
    assert joined == whole
    for record in whole.files:
        assert (tmp_path / "joined" / record.path).read_bytes() == (tmp_path / "whole" / record.path).read_bytes()


def test_frames_read_in_any_order_from_row_groups_of_several_frames(tmp_path, monkeypatch):
    from simgen.datasets.formats import parquet
    from tests.support.datasets import make_clip

    monkeypatch.setattr(parquet, "POINTS_FRAMES_PER_GROUP", 3)  # 11 frames: groups of 3, 3, 3 and 2
    frames = make_clip("clip_0000", 11, points=40, seed=4)
    frames[4] = make_clip("clip_0000", 1, points=0, seed=5)[0]  # a frame without points inside a group
    frames = [LabelledFrame(f.clip, i, f.time_s, f.label_time_s, f.scan, f.labels) for i, f in enumerate(frames)]
    write_dataset(tmp_path, "parquet", [frames])
    groups = pq.ParquetFile(tmp_path / "points/clip_0000/part-0.parquet").metadata.num_row_groups
    assert groups == 4
    reader = simgen.datasets.open(tmp_path)
    for index in np.random.default_rng(0).permutation(11):
        np.testing.assert_array_equal(reader.frame("clip_0000", int(index)).points_m, frames[index].scan.points_m)


def test_point_counts_that_disagree_with_the_points_are_refused(tmp_path):
    write_dataset(tmp_path, "parquet", CLIPS[:1])
    relative = "frames/clip_0000/part-0.parquet"
    table = pq.read_table(tmp_path / relative, partitioning=None)
    counts = table["num_points"].to_numpy().copy()
    counts[0], counts[1] = counts[0] + 1, counts[1] - 1  # same total in the row group: only the frames' split is wrong
    index = table.schema.get_field_index("num_points")
    pq.write_table(
        table.set_column(index, table.schema.field(index), pa.array(counts, pa.int32())), tmp_path / relative
    )
    manifest = json.loads((tmp_path / MANIFEST_NAME).read_text())
    for entry in manifest["files"]:
        if entry["path"] == relative:
            entry.update(bytes=(tmp_path / relative).stat().st_size, sha256=sha256_file(tmp_path / relative))
    (tmp_path / MANIFEST_NAME).write_text(json.dumps(manifest))
    with pytest.raises(UserError, match=r"frame 0's points are not where the frames table counts them$"):
        simgen.datasets.open(tmp_path).frame("clip_0000", 0)
