"""Reproducible bytes, atomic writes, and a reader that refuses corrupt, missing or foreign files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import simgen.datasets
import simgen.datasets.formats.parquet
from simgen.datasets import FORMATS, write_clip
from simgen.datasets.manifest import MANIFEST_NAME
from simgen.datasets.schema import SCHEMA_VERSION
from simgen.errors import UserError
from simgen.labels.labelled_frame import LabelledFrame
from tests.support.datasets import make_clip, sample_clips, sensors, write_dataset

CLIPS = sample_clips()[:2]
# A file of each kind, per format, and the frame that reads it.
CORRUPTIBLE = [
    ("parquet", "points/clip_0001/part-0.parquet"),
    ("parquet", "boxes/clip_0001/part-0.parquet"),
    ("kitti", "training/velodyne/010002.bin"),
    ("kitti", "training/label_2/010002.txt"),
    ("kitti_tracking", "training/velodyne/0001/000002.bin"),
    ("kitti_tracking", "training/label_02/0001.txt"),
    ("openpcdet", "points/010002.npy"),
    ("openpcdet", "labels/010002.txt"),
    ("mcap", "clip_0001/clip_0001.mcap"),
]


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("format", FORMATS)
def test_same_input_gives_the_same_bytes(tmp_path, format):
    first = write_dataset(tmp_path / "a", format, CLIPS)
    write_dataset(tmp_path / "b", format, [make_clip(c[0].clip, len(c), seed=i) for i, c in enumerate(CLIPS)])
    a, b = _files(tmp_path / "a"), _files(tmp_path / "b")
    assert a == b
    listed = {f.path for f in first.files}
    assert set(a) == listed | {MANIFEST_NAME, "README.md"}  # every file is in the manifest, nothing else is written
    assert not [name for name in a if ".tmp" in name]


@pytest.mark.parametrize("format, relative", CORRUPTIBLE)
def test_a_flipped_byte_is_an_error_naming_the_file(tmp_path, format, relative):
    write_dataset(tmp_path, format, CLIPS)
    path = tmp_path / relative
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    data_set = simgen.datasets.open(tmp_path)
    data_set.frame("clip_0000", 1)  # other files still read
    with pytest.raises(UserError, match=f"{path}: sha256 differs from manifest.json"):
        data_set.frame("clip_0001", 2)
    with pytest.raises(UserError, match=str(path)):
        simgen.datasets.open(tmp_path).verify()


def test_missing_and_truncated_files_are_named(tmp_path):
    write_dataset(tmp_path, "kitti", CLIPS)
    (tmp_path / "training/velodyne/000001.bin").unlink()
    truncated = tmp_path / "training/velodyne/000002.bin"
    truncated.write_bytes(truncated.read_bytes()[:-16])
    data = simgen.datasets.open(tmp_path)
    with pytest.raises(UserError, match=r"000001\.bin: missing"):
        data.frame("clip_0000", 1)
    with pytest.raises(UserError, match=r"000002\.bin: .* bytes, manifest\.json says"):
        data.frame("clip_0000", 2)


def test_manifest_missing_malformed_or_foreign(tmp_path):
    with pytest.raises(UserError, match=r"no manifest\.json, not a simgen dataset"):
        simgen.datasets.open(tmp_path)
    (tmp_path / MANIFEST_NAME).write_text("{")
    with pytest.raises(UserError, match=r"manifest\.json: not a readable manifest"):
        simgen.datasets.open(tmp_path)
    (tmp_path / MANIFEST_NAME).write_text(json.dumps({"schema_version": SCHEMA_VERSION + 1, "format": "parquet"}))
    with pytest.raises(
        UserError, match=f"dataset schema version {SCHEMA_VERSION + 1}, this simgen reads {SCHEMA_VERSION}"
    ):
        simgen.datasets.open(tmp_path)
    with pytest.raises(UserError, match="no such dataset directory"):
        simgen.datasets.open(tmp_path / "nowhere")


def test_a_failed_write_leaves_no_file_under_its_final_name(tmp_path, monkeypatch):
    def fail(frame):
        raise RuntimeError("disk full")

    monkeypatch.setattr(simgen.datasets.formats.parquet, "points_table", fail)
    with pytest.raises(RuntimeError, match="disk full"):
        write_clip(tmp_path, "parquet", CLIPS[0], sensors(), 0)
    written = [str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.is_file()]
    assert written == []  # the clip's tables are written together, frame by frame: none renamed, no temporary left


def test_bad_clips_are_one_line_errors(tmp_path):
    frames = CLIPS[0]
    with pytest.raises(UserError, match="unknown dataset format 'las'"):
        write_clip(tmp_path, "las", frames, sensors(), 0)
    with pytest.raises(UserError, match="no frames to write"):
        write_clip(tmp_path, "parquet", [], sensors(), 0)
    with pytest.raises(UserError, match="frame 0 is frame 1 of clip clip_0000"):
        write_clip(tmp_path, "kitti", frames[1:], sensors(), 0)
    renamed = [LabelledFrame("0003", f.index, f.time_s, f.label_time_s, f.scan, f.labels) for f in frames]
    with pytest.raises(UserError, match="clip id '0003': use a letter"):
        write_clip(tmp_path, "parquet", renamed, sensors(), 0)
    labels = frames[0].labels
    home = type(labels)(**{**labels.__dict__, "team": np.full(len(labels.team), "home")})
    foreign = LabelledFrame(frames[0].clip, 0, 0.0, 0.0, frames[0].scan, home)
    with pytest.raises(UserError, match="unknown team 'home'"):
        write_clip(tmp_path, "openpcdet", [foreign], sensors(), 0)
    assert not any(tmp_path.iterdir())


def test_clips_of_one_dataset_must_not_collide(tmp_path):
    record = write_clip(tmp_path, "kitti", CLIPS[0], sensors(), 0)
    with pytest.raises(UserError, match="two clips have the same clip index"):
        simgen.datasets.finish_dataset(tmp_path, "kitti", [record, record], sensors(), {}, 0)
    with pytest.raises(UserError, match="no clips written"):
        simgen.datasets.finish_dataset(tmp_path, "kitti", [], sensors(), {}, 0)


def test_parquet_page_checksums_guard_even_unverified_reads(tmp_path):
    write_dataset(tmp_path, "parquet", CLIPS)
    path = tmp_path / "points/clip_0001/part-0.parquet"
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x01
    path.write_bytes(bytes(data))
    data_set = simgen.datasets.open(tmp_path, verify=False)
    with pytest.raises(UserError, match=str(path)):
        for index in range(len(CLIPS[1])):
            data_set.frame("clip_0001", index)
