"""`simgen pattern`: the official file's layout on disk, one-line errors, nothing half-written."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.cli import main
from tests.support.processes import run_simgen


def test_mid40_risley_export_is_the_official_file(tmp_path):
    from scan_patterns.replay import resolve

    official = np.load(resolve("mid40"))
    out = tmp_path / "shots.npz"
    assert main(["pattern", "mid40-risley", "--seconds", "4", "-o", str(out)]) == 0
    with np.load(out) as data:
        assert {"t_s", "azimuth_deg", "zenith_deg", "head", "line"} <= set(data.files)
        assert data["t_s"].dtype == np.float64 and data["head"].dtype == np.uint8
        np.testing.assert_allclose(data["t_s"], official["t_s"], atol=1e-9)
        assert np.abs(data["azimuth_deg"] - official["azimuth_deg"]).max() < 2e-5  # 3.0e-6 measured
        assert np.abs(data["zenith_deg"] - official["zenith_deg"]).max() < 2e-5  # 1.12e-5 measured
    assert [p.name for p in tmp_path.iterdir()] == ["shots.npz"]


def test_mid100_export_applies_head_yaw_and_density(tmp_path):
    out = tmp_path / "mid100.npz"
    assert main(["pattern", "mid100-rose", "--seconds", "0.1", "--density", "2", "--start", "3", "-o", str(out)]) == 0
    with np.load(out) as data:
        assert np.bincount(data["head"]).tolist() == [20_000] * 3
        assert data["t_s"].min() > 3.0 and data["t_s"].max() <= 3.1 + 1e-9
        for head, yaw in enumerate((-30, 0, 30)):
            assert np.median(data["azimuth_deg"][data["head"] == head]) == pytest.approx(yaw, abs=3)


@pytest.mark.parametrize(
    "args, message",
    [
        (["mid40-rosette", "--seconds", "1"], "unknown sensor 'mid40-rosette'"),
        (["mid40-rose", "--seconds", "-1"], "--seconds must be a positive number"),
        (["mid40-rose", "--seconds", "1", "--density", "0"], "--density must be a positive number"),
        (["mid40-rose", "--seconds", "1", "--density", "-2"], "--density must be a positive number"),
        (["mid40-rose", "--seconds", "1", "--start", "-1"], "--start must be zero or positive"),
        (["mid100-rose", "--seconds", "1e6"], "shots is more than"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, message):
    result = run_simgen("pattern", *args, "-o", tmp_path / "x.npz")
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_unwritable_output_is_one_line(tmp_path):
    result = run_simgen("pattern", "mid40-rose", "--seconds", "0.01", "-o", tmp_path / "missing" / "x.npz")
    assert result.returncode == 2 and "output directory does not exist" in result.stderr


def test_looping_replay_warns_on_stderr(tmp_path):
    result = run_simgen("pattern", "mid40-replay", "--seconds", "1", "--start", "3.5", "-o", tmp_path / "r.npz")
    assert result.returncode == 0
    assert "warning: replay of mid40_official_4s.npz loops past the file's end" in result.stderr


def test_help_lists_the_presets():
    result = run_simgen("pattern", "--help")
    assert result.returncode == 0
    for preset in ("mid40-risley", "mid40-rose", "mid40-replay", "mid70-replay", "mid100-risley", "mid100-rose",
                   "avia-replay", "horizon-replay", "tele15-replay", "hap-replay", "mid360-replay",
                   "avia-risley", "tele15-risley", "horizon-risley", "mid70-risley", "mid360-rotors",
                   "hap-rotors"):
        assert preset in result.stdout
