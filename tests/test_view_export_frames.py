"""`simgen view --export-frame` takes a frame or a range A:B: a PCD/PLY per frame, each frame once."""

from __future__ import annotations

import open3d as o3d

import simgen.datasets
from simgen.cli import main
from tests.support.datasets import make_clip, write_dataset


def test_a_range_and_a_frame_export_each_frame_once(tmp_path, capsys):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 5, points=100)])
    out = tmp_path / "v"
    assert main(["view", str(tmp_path / "d"), "-o", str(out), "--no-images", "--export-frame", "1:4",
                 "--export-frame", "2"]) == 0
    assert sorted(p.name for p in (out / "clip_0000").iterdir()) == [f"frame_{i:06d}.pcd" for i in (1, 2, 3)]
    assert capsys.readouterr().out.count(".pcd: ") == 3
    data = simgen.datasets.open(tmp_path / "d")
    for index in (1, 2, 3):
        cloud = o3d.t.io.read_point_cloud(str(out / "clip_0000" / f"frame_{index:06d}.pcd"))
        assert len(cloud.point.positions) == len(data.frame("clip_0000", index).points_m)


def test_a_range_outside_the_clip_is_one_line_naming_the_option(tmp_path, capsys):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 3, points=50)])
    assert main(["view", str(tmp_path / "d"), "-o", str(tmp_path / "v"), "--no-images", "--export-frame", "1:9"]) == 2
    assert capsys.readouterr().err == "simgen view: error: --export-frame 1:9: the clip has frames 0-2\n"
