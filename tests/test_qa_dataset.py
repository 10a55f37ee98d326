"""`simgen qa`, `view` and `verify` on a dataset the real engine made."""

from __future__ import annotations

import shutil
import subprocess

import cv2
import numpy as np
import open3d as o3d
import pytest

import simgen.datasets as datasets
from simgen.qa.report import data_uri
from tests.support import ROOT
from tests.support.processes import run_simgen

pytestmark = pytest.mark.engine
FRAMES = 6


@pytest.fixture(scope="session")
def smoke_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("qa_smoke") / "dataset"
    result = run_simgen("generate", ROOT / "scenarios" / "smoke.yaml", "-o", out, "--frames", FRAMES)
    assert result.returncode == 0, result.stderr[-2000:]
    return out


def test_qa_of_a_dataset_passes_with_its_plots(smoke_dataset, tmp_path):
    result = run_simgen("qa", smoke_dataset, "-o", tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    assert any(line.startswith("pass") and "integrity (simgen verify)" in line for line in lines)
    assert any(
        line.startswith("pass") and "mid100-risley head 2" in line and "coverage, 0.2 deg" in line for line in lines
    )
    assert lines[-1].startswith("PASS: 22 passed, 0 failed")
    html = (tmp_path / "index.html").read_text()
    for image in ("humanoids.png", "frames.png", "pattern_mid100-risley.png", "coverage_mid100-risley.png"):
        assert (
            f'src="{data_uri(tmp_path / "plots" / image)}"' in html
            and (tmp_path / "plots" / image).stat().st_size > 10_000
        )


def test_view_writes_pngs_and_an_mp4_that_reads_back(smoke_dataset, tmp_path):
    result = run_simgen("view", smoke_dataset, "-o", tmp_path, "--frames", "1:", "--export-frame", "2")
    assert result.returncode == 0, result.stderr
    pngs = sorted((tmp_path / "clip_0000").glob("*.png"))
    assert [p.name for p in pngs] == [f"frame_{i:06d}.png" for i in range(1, FRAMES)]
    first = cv2.imread(str(pngs[0]))
    video = cv2.VideoCapture(str(tmp_path / "clip_0000.mp4"))
    frames = []
    while (read := video.read())[0]:
        frames.append(read[1])
    assert len(frames) == FRAMES - 1 and frames[0].shape == first.shape
    assert np.abs(frames[0].astype(int) - first).mean() < 8  # the same picture, through a lossy codec
    cloud = o3d.t.io.read_point_cloud(str(tmp_path / "clip_0000" / "frame_000002.pcd"))
    frame = datasets.open(smoke_dataset).frame("clip_0000", 2)
    np.testing.assert_array_equal(cloud.point.positions.numpy(), frame.points_m)
    np.testing.assert_array_equal(cloud.point.intensity.numpy()[:, 0], frame.intensity)


def test_view_exports_ply_only_and_refuses_bad_frames(smoke_dataset, tmp_path):
    result = run_simgen(
        "view", smoke_dataset, "-o", tmp_path, "--export-frame", "0", "--export-format", "ply", "--no-images"
    )
    assert result.returncode == 0, result.stderr
    assert [p.name for p in (tmp_path / "clip_0000").iterdir()] == ["frame_000000.ply"]
    result = run_simgen("view", smoke_dataset, "-o", tmp_path, "--frames", "3:99")
    assert (
        result.returncode == 2
        and result.stderr == f"simgen view: error: --frames 3:99: the clip has frames 0-{FRAMES - 1}\n"
    )


def test_verify_names_a_shard_with_a_flipped_byte(smoke_dataset, tmp_path):
    result = run_simgen("verify", smoke_dataset)
    assert result.returncode == 0 and result.stdout.endswith(
        f"ok (5 files, {FRAMES} frames, {FRAMES * 25} boxes checked)\n"
    )
    copy = tmp_path / "copy"
    shutil.copytree(smoke_dataset, copy)
    shard = copy / "points" / "clip_0000" / "part-0.parquet"
    data = bytearray(shard.read_bytes())
    data[len(data) // 3] ^= 0x10
    shard.write_bytes(bytes(data))
    result = run_simgen("verify", copy)
    assert result.returncode == 1
    assert result.stdout.splitlines()[0] == f"{shard}: sha256 differs from manifest.json (corrupt or modified)"


def test_the_report_and_the_card_name_no_folder_of_this_machine(smoke_dataset, tmp_path):
    """A report or card attached to a ticket shows no one's disk: `grep -r` of the working directory (the
    repository, where the shipped tolerances live), the dataset's folder and the report's finds nothing."""
    copy, out = tmp_path / "copy", tmp_path / "qa"
    shutil.copytree(smoke_dataset, copy)
    (copy / "points" / "notes.txt").write_text("not data\n")  # so that the report lists a problem at a file
    result = run_simgen("qa", copy, "-o", out)
    assert result.returncode == 1, result.stderr
    report = (out / "report.md").read_text()
    assert "tolerances from simgen/qa/tolerances.yaml (shipped)" in report
    assert "| copy/points/notes.txt |" in report and report.startswith("# Dataset QA: copy")
    for folder in (ROOT, tmp_path):
        grep = subprocess.run(
            ["grep", "-rlF", str(folder), str(out), str(copy / "README.md")], capture_output=True, text=True
        )
        assert grep.returncode == 1 and grep.stdout == "", grep.stdout
