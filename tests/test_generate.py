"""`simgen generate` end to end: formats agree, executors, worker counts and shard sizes agree, runs
resume (between clips and in the middle of a clip's shards), runs lock."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

import simgen.datasets as datasets
from tests.support import ROOT
from tests.support.processes import local_ray_cluster, run_simgen

pytestmark = pytest.mark.engine
SMOKE = ROOT / "scenarios" / "smoke.yaml"
DUCKDB = shutil.which("duckdb") or str(ROOT / ".venv" / "bin" / "duckdb")


def generate(out, *extra):
    result = run_simgen("generate", SMOKE, "-o", out, "--frames", 6, "--clips", 2, *extra)
    assert result.returncode == 0, result.stderr[-2000:]
    return result


def manifest_files(path) -> dict:
    return {f["path"]: f["sha256"] for f in json.loads((path / "manifest.json").read_text())["files"]}


@pytest.fixture(scope="module")
def parquet_dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "parquet"
    result = generate(out)
    return out, result.stdout


def test_duckdb_counts_the_points_the_summary_printed(parquet_dataset):
    out, summary = parquet_dataset
    printed = int(next(line for line in summary.splitlines() if line.startswith("points")).split()[1].replace(",", ""))
    query = subprocess.run(
        [DUCKDB, "-csv", "-noheader", "-c", f"select count(*) from '{out}/points/**/*.parquet'"],
        capture_output=True, text=True, check=True,
    )
    assert int(query.stdout.strip()) == printed > 0
    assert not (out / ".simgen").exists()


@pytest.mark.parametrize("fmt", ["kitti", "kitti_tracking", "openpcdet", "mcap"])
def test_other_formats_round_trip_to_the_parquet_frames(parquet_dataset, tmp_path, fmt):
    reference = datasets.open(parquet_dataset[0])
    other = datasets.open(generate(tmp_path / fmt, "--format", fmt) and tmp_path / fmt)
    assert len(other) == len(reference) == 12
    for clip_a, clip_b in zip(reference.clips, other.clips):
        for index in range(reference.num_frames(clip_a)):
            a, b = reference.frame(clip_a, index), other.frame(clip_b, index)
            np.testing.assert_array_equal(a.points_m, b.points_m)
            np.testing.assert_array_equal(a.intensity, b.intensity)
            np.testing.assert_allclose(a.boxes[:, :6], b.boxes[:, :6], rtol=0, atol=1e-6)
            np.testing.assert_allclose(np.cos(a.boxes[:, 6] - b.boxes[:, 6]), 1.0, atol=1e-6)
            # bag stamps are whole nanoseconds; the others' times are exact
            tolerance = 0.5e-9 if fmt == "mcap" else 0.0
            assert a.time_s == pytest.approx(b.time_s, abs=tolerance) and a.label_time_s == pytest.approx(
                b.label_time_s, abs=tolerance
            )
    if fmt == "kitti":  # the same clip exported from both: the same stamps
        stamps = [
            _bag_stamps(tmp_path / f"{name}_bag", dataset)
            for name, dataset in (("parquet", parquet_dataset[0]), ("kitti", tmp_path / fmt))
        ]
        assert stamps[0] == stamps[1] and len(stamps[0]) == 2 * 6 + 1


def _bag_stamps(bag, dataset) -> list[tuple[str, int, int]]:
    """(kind, log time, header stamp) of every message of `simgen export DATASET -o BAG`, in order."""
    result = run_simgen("export", dataset, "-o", bag, "--clip", "clip_0001")
    assert result.returncode == 0, result.stderr
    out = []
    with (bag / f"{bag.name}.mcap").open("rb") as stream:
        for _, channel, message, decoded in make_reader(
            stream, decoder_factories=[DecoderFactory()]
        ).iter_decoded_messages():
            kind = channel.topic.rsplit("/", 1)[-1]  # points, boxes, tf_static
            header = (
                decoded.markers[0].header
                if kind == "boxes"
                else decoded.transforms[0].header
                if kind == "tf_static"
                else decoded.header
            )
            out.append((kind, message.log_time, header.stamp.sec * 1_000_000_000 + header.stamp.nanosec))
    return out


def test_workers_shards_and_seeds(parquet_dataset, tmp_path):
    two = tmp_path / "two"
    generate(two, "--workers", "2")
    assert manifest_files(two) == manifest_files(parquet_dataset[0])
    for shard_frames, workers in (("1", "1"), ("4", "2")):  # partial clips joined into the final files
        sharded = tmp_path / f"shards{shard_frames}"
        generate(sharded, "--shard-frames", shard_frames, "--workers", workers)
        assert manifest_files(sharded) == manifest_files(parquet_dataset[0])
    other = tmp_path / "other"
    generate(other, "--seed", "8")
    assert manifest_files(other) != manifest_files(parquet_dataset[0])


def test_ray_executor_matches_local(parquet_dataset, tmp_path):
    out, sharded = tmp_path / "ray", tmp_path / "ray_shards"
    with local_ray_cluster() as address:
        generate(out, "--executor", "ray", "--address", address)
        generate(sharded, "--executor", "ray", "--address", address, "--shard-frames", "4")
    assert manifest_files(out) == manifest_files(parquet_dataset[0])
    assert manifest_files(sharded) == manifest_files(parquet_dataset[0])


@pytest.mark.parametrize("fmt", ["kitti_tracking", "openpcdet", "kitti"])
def test_sharded_formats_match_whole_clips(tmp_path, fmt):
    """kitti_tracking joins its shards' partial clips; KITTI's and OpenPCDet's shards write their frames in
    place, and their label statistics still count the frame pair at each seam: the same manifest and card."""
    generate(tmp_path / "whole", "--format", fmt)
    generate(tmp_path / "sharded", "--format", fmt, "--shard-frames", "4", "--workers", "2")
    assert manifest_files(tmp_path / "sharded") == manifest_files(tmp_path / "whole")
    for name in ("manifest.json", "README.md"):
        assert (tmp_path / "sharded" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()


def kill_when_recorded(out, pattern: str, *arguments) -> None:
    """Start `simgen generate` into `out` and SIGKILL it as soon as a run-state marker matches `pattern`."""
    command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out), *arguments]
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while not list((out / ".simgen").glob(pattern)) and time.time() < deadline:
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert not (out / "manifest.json").exists()


def test_killed_run_resumes_to_the_same_manifest(parquet_dataset, tmp_path):
    out = tmp_path / "killed"
    kill_when_recorded(out, "clips/*.json", "--frames", "6", "--clips", "2")
    again = run_simgen("generate", SMOKE, "-o", out, "--frames", 6, "--clips", 2)
    assert again.returncode == 2 and "--resume" in again.stderr
    resumed = generate(out, "--resume")
    assert "1 kept from the interrupted run" in resumed.stdout
    assert manifest_files(out) == manifest_files(parquet_dataset[0])
    assert not [p for p in out.rglob("*") if ".tmp-" in p.name]  # the killed writer's temporaries are gone


def test_killed_in_the_middle_of_a_clip_resumes_its_shards(parquet_dataset, tmp_path):
    out = tmp_path / "killed"
    sharded = ("--frames", "6", "--clips", "2", "--shard-frames", "2")
    kill_when_recorded(out, "shards/*/*.json", *sharded)
    assert not list((out / ".simgen" / "clips").glob("*.json"))  # killed in the middle of clip 0
    # its capture is kept (the plan is written last), and its first shard
    assert (out / ".simgen" / "motion" / "0000.json").exists()
    resumed = run_simgen("generate", SMOKE, "-o", out, *sharded, "--resume")
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert manifest_files(out) == manifest_files(parquet_dataset[0])
    assert not (out / ".simgen").exists() and not [p for p in out.rglob("*") if ".tmp-" in p.name]


def test_a_second_run_into_the_same_directory_is_refused(tmp_path):
    out = tmp_path / "locked"
    command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out),
               "--frames", "6", "--clips", "6"]
    first = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 60
        while not (out / ".simgen" / "lock").exists() and time.time() < deadline:
            time.sleep(0.02)
        time.sleep(0.2)
        second = run_simgen("generate", SMOKE, "-o", out, "--frames", 6, "--clips", 6, "--resume")
        assert first.poll() is None, "the first run ended before the second tried"
        assert second.returncode == 2
        assert second.stderr.count("\n") == 1 and "another simgen generate is writing here" in second.stderr
    finally:
        first.wait(timeout=300)
    assert first.returncode == 0 and (out / "manifest.json").exists()


def test_overwrite_keeps_its_run_state_inside_the_output(tmp_path):
    # an --overwrite of a finished dataset once wrote its resume record to ./shards in the caller's folder
    out, cwd = tmp_path / "dataset", tmp_path / "elsewhere"
    cwd.mkdir()
    command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out),
               "--frames", "3", "--overwrite"]
    for _ in range(2):
        done = subprocess.run(
            command, cwd=cwd, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}
        )
        assert done.returncode == 0, done.stderr
    assert list(cwd.iterdir()) == []
    assert (out / "manifest.json").is_file() and not (out / ".simgen").exists()
