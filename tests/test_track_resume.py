"""`simgen-train track --resume`: a run killed after a completed chunk goes on from it and writes what an
uninterrupted run writes, byte for byte; given other options it refuses in one line."""

from __future__ import annotations

import filecmp
import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from tests.support import ROOT
from tests.support.kitti_detections import write_detections
from train.evaluation.frame_log import CHUNK_FRAMES
from train.track.outputs import PARTIAL
from train.track.resume import STATE

FRAMES = 3 * CHUNK_FRAMES  # a kill after the first chunk leaves two to go


@pytest.fixture(scope="module")
def long_clip(tmp_path_factory):
    """(dataset, detections): one clip of smoke's match, 300 frames, the sensors at 5 % of their shots."""
    root = tmp_path_factory.mktemp("resume")
    scenario = yaml.safe_load((ROOT / "scenarios" / "smoke.yaml").read_text())
    scenario["motion"]["frames"] = FRAMES
    (root / "smoke.yaml").write_text(yaml.safe_dump(scenario))
    done = subprocess.run([sys.executable, "-m", "simgen.cli", "generate", root / "smoke.yaml", "-o", root / "data",
                           "--frames", str(FRAMES), "--clips", "1", "--density", "0.05"],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr
    write_detections(root / "data", root / "detections", np.random.default_rng(0))
    return root / "data", root / "detections"


def _track(dataset, detections, out, *more: str) -> list[str]:
    return [sys.executable, "-m", "train.cli", "track", "--dataset", str(dataset), "--detections", str(detections),
            "-o", str(out), "--split", "all", "--quiet", *more]


def _next_frame(out) -> int:
    """The frame the interrupted run's state goes on from; 0 while there is none."""
    try:
        with np.load(out / PARTIAL / STATE, allow_pickle=False) as state:
            return json.loads(state["meta"].tobytes())["next"]
    except (OSError, ValueError, KeyError):
        return 0


def _files(folder) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


@pytest.mark.engine
def test_a_killed_run_resumed_writes_what_an_uninterrupted_one_does(long_clip, tmp_path):
    dataset, detections = long_clip
    whole = subprocess.run(_track(dataset, detections, tmp_path / "whole"), capture_output=True, text=True,
                           cwd=ROOT, timeout=600)
    assert whole.returncode == 0, whole.stderr
    killed = subprocess.Popen(_track(dataset, detections, tmp_path / "resumed"), cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while killed.poll() is None and _next_frame(tmp_path / "resumed") < CHUNK_FRAMES:
        time.sleep(0.01)
    killed.send_signal(signal.SIGKILL)
    assert killed.wait() == -signal.SIGKILL, "the run ended before it could be killed"
    assert CHUNK_FRAMES <= _next_frame(tmp_path / "resumed") < FRAMES
    assert not (tmp_path / "resumed" / "tracks.parquet").exists()

    other = subprocess.run(_track(dataset, detections, tmp_path / "resumed", "--resume", "--min-score", "0.5"),
                           capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert other.returncode == 2 and len(other.stderr.strip().splitlines()) == 1 and "other options" in other.stderr

    resumed = subprocess.run(_track(dataset, detections, tmp_path / "resumed", "--resume"), capture_output=True,
                             text=True, cwd=ROOT, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert resumed.stdout.splitlines()[1:] == whole.stdout.splitlines()[1:]  # the metrics (line 0: OUT and time)
    names = _files(tmp_path / "whole")
    assert names == _files(tmp_path / "resumed") and "tracks.parquet" in names and PARTIAL not in str(names)
    for name in names:
        if name != "metrics.md":  # which quotes the command
            assert filecmp.cmp(tmp_path / "whole" / name, tmp_path / "resumed" / name, shallow=False), name
    whole_md, resumed_md = ([line for line in (tmp_path / out / "metrics.md").read_text().splitlines()
                             if "--quiet" not in line] for out in ("whole", "resumed"))
    assert whole_md == resumed_md
