"""`simgen export --format las`: one LAS 1.4 file of a clip's frames, which laspy reads back equal to the Parquet
dataset: counts, coordinates (to the file's scale), GPS times (the shots' game times), classes (the semantic
classes) and point source ids (the lidar units)."""

from __future__ import annotations

import laspy
import numpy as np

import simgen.datasets
from simgen.cli import main
from simgen.datasets.las import CLASS_CODES, SCALE_M, classification
from simgen.datasets.units import unit_numbers
from simgen.vocab import SEMANTIC_NAMES
from tests.support.datasets import make_clip, sensors, write_dataset


def test_laspy_reads_the_frames_back_as_parquet_has_them(tmp_path, capsys):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 4, points=300)])
    out = tmp_path / "clip.las"
    assert main(["export", str(tmp_path / "d"), "--format", "las", "-o", str(out), "--frames", "1:4"]) == 0
    data = simgen.datasets.open(tmp_path / "d")
    frames = [data.frame("clip_0000", i) for i in range(1, 4)]
    total = sum(len(f.points_m) for f in frames)
    summary = f"{out}: 3 frames of clip_0000, {total:,} points (LAS 1.4, point format 6)\n"
    assert capsys.readouterr().out.endswith(summary)
    las = laspy.read(out)
    assert las.header.point_count == len(las.points) == total and las.header.version == "1.4"
    xyz = np.concatenate([f.points_m for f in frames]).astype(np.float64)
    got = np.stack([las.x, las.y, las.z], axis=1)
    assert np.all(np.abs(got - xyz) <= SCALE_M / 2 * (1 + 1e-6))  # rounded to the file's scale, no further
    shots = np.concatenate([f.time_s + f.time_offset_s.astype(np.float64) for f in frames])
    np.testing.assert_array_equal(las.gps_time, shots)
    semantic = np.concatenate([f.semantic for f in frames])
    np.testing.assert_array_equal(las.classification, classification(semantic))
    assert {SEMANTIC_NAMES[s] for s in semantic} >= {"ground", "player", "official", "ball"}
    units = np.concatenate([unit_numbers(f.sensor, f.head, sensors()) for f in frames])
    np.testing.assert_array_equal(las.point_source_id, units)
    assert set(units) == {0, 1, 2}  # the Mid-100's three units
    np.testing.assert_array_equal(las.intensity // 257, np.concatenate([f.intensity for f in frames]))
    np.testing.assert_array_equal(las.instance_id, np.concatenate([f.instance_id for f in frames]))
    np.testing.assert_array_equal(las.line, np.concatenate([f.line for f in frames]))
    (lookup,) = [v for v in las.header.vlrs if isinstance(v, laspy.vlrs.known.ClassificationLookupVlr)]
    assert {lookup[code]: code for code in lookup.lookups} == CLASS_CODES
    again = tmp_path / "again.las"
    assert main(["export", str(tmp_path / "d"), "--format", "las", "-o", str(again), "--frames", "1:4"]) == 0
    assert again.read_bytes() == out.read_bytes()  # same frames, same bytes


def test_a_dataset_without_shot_times_is_refused_in_one_line(tmp_path, capsys):
    write_dataset(tmp_path / "k", "kitti", [make_clip("clip_0000", 2, points=100)])
    assert main(["export", str(tmp_path / "k"), "--format", "las", "-o", str(tmp_path / "k.las")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--format las: a kitti dataset keeps no shot time" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["k"]
