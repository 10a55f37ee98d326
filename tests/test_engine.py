"""The live engine: `simgen capture` drives the real, patched Google Research Football."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.motion.clip_io import read_clip
from tests.support import ROOT
from tests.support.clips import assert_plausible_skeletons
from tests.support.processes import run_simgen

pytestmark = pytest.mark.engine
SMOKE = ROOT / "scenarios" / "smoke.yaml"


@pytest.fixture(scope="module")
def live_clip(tmp_path_factory):
    path = tmp_path_factory.mktemp("live") / "m.parquet"
    result = run_simgen("capture", SMOKE, "-o", path, "--frames", 100)
    assert result.returncode == 0, result.stderr
    assert "100 frames" in result.stdout and str(path) in result.stdout
    return path


def test_capture_100_frames_acceptance(live_clip):
    clip = read_clip(live_clip)
    assert clip.num_frames == 100
    assert clip.keypoints_m.shape == (100, 25, 12, 3)  # 22 players, the referee and two linesmen
    assert list(clip.team).count("official") == 3
    np.testing.assert_allclose(np.diff(clip.time_s), 0.1, atol=1e-9)
    assert_plausible_skeletons(clip)


def test_same_seed_same_bytes_other_seed_differs(live_clip, tmp_path):
    again = tmp_path / "again.parquet"
    other = tmp_path / "other.parquet"
    assert run_simgen("capture", SMOKE, "-o", again, "--frames", 100).returncode == 0
    assert run_simgen("capture", SMOKE, "-o", other, "--frames", 100, "--seed", 8).returncode == 0
    assert again.read_bytes() == live_clip.read_bytes()
    assert not np.array_equal(read_clip(other).keypoints_m, read_clip(again).keypoints_m)


def test_capture_frames_need_not_cover_the_scenarios_scan(tmp_path):
    # paper_x1 scans 205 frames of 18.6 s; capture only plays the engine, so 30 frames (0.3 s) are fine
    path = tmp_path / "short.parquet"
    result = run_simgen("capture", ROOT / "scenarios" / "paper_x1.yaml", "-o", path, "--frames", 30)
    assert result.returncode == 0, result.stderr
    assert read_clip(path).num_frames == 30


def test_capture_at_100_hz_is_smooth(tmp_path):
    scenario = tmp_path / "fine.yaml"
    scenario.write_text("name: fine\nseed: 2\nmotion:\n  frames: 60\n  capture_hz: 100\n  skip_s: 3\n")
    path = tmp_path / "fine.parquet"
    result = run_simgen("capture", scenario, "-o", path)
    assert result.returncode == 0, result.stderr
    clip = read_clip(path)
    np.testing.assert_allclose(np.diff(clip.time_s), 0.01, atol=1e-9)
    assert clip.time_s[0] == pytest.approx(3.01)
    # Every 10 ms sample is new (players move between physics steps), and no joint jumps: a kicking
    # foot reaches about 25 m/s; nothing may move 40 m/s (0.4 m in 10 ms).
    moved = np.abs(np.diff(clip.keypoints_m, axis=0)).max(axis=(1, 2, 3))
    assert (moved > 0).all()
    assert np.linalg.norm(np.diff(clip.keypoints_m, axis=0), axis=-1).max() < 0.4


def test_unknown_level_and_bad_output_are_one_line_errors(tmp_path):
    scenario = tmp_path / "bad.yaml"
    scenario.write_text("name: bad\nmotion:\n  level: no_such_level\n")
    for args, expected in [
        (("capture", scenario, "-o", tmp_path / "x.parquet"), "unknown GRF level 'no_such_level'"),
        (("capture", SMOKE, "-o", tmp_path / "missing_dir" / "x.parquet"), "output directory does not exist"),
        (("capture", SMOKE, "-o", tmp_path / "x.csv"), "a motion clip is a .parquet file"),
        (("capture", SMOKE, "-o", tmp_path / "x.parquet", "--frames", "0"), "'motion.frames'"),
    ]:
        result = run_simgen(*args)
        assert result.returncode == 2, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1 and expected in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == [scenario]
