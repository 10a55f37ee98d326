"""`replay`: official files (npz and Livox CSV) replayed with continuous time, loudly when looping."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns.replay import load_pattern_file, resolve
from scan_patterns.shots import angle_between_deg, livox_angles


@pytest.mark.parametrize("preset, source", [("mid40-replay", "mid40"), ("mid70-replay", "mid70")])
def test_x1_replay_of_the_first_4_s_is_the_file_and_silent(preset, source):
    head = sp.get_sensor(preset).heads[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", sp.PatternLoopWarning)
        shots = sp.head_shots(head, 0.0, 4.0)
    with np.load(resolve(source)) as data:
        azimuth_deg, zenith_deg, t_s = data["azimuth_deg"], data["zenith_deg"], data["t_s"]
    np.testing.assert_allclose(shots.t_s, t_s, atol=1e-9)
    azimuth, zenith = livox_angles(shots.dirs)
    assert np.abs(azimuth - azimuth_deg).max() < 1e-4 and np.abs(zenith - zenith_deg).max() < 1e-4


def test_a_window_past_the_file_warns_and_repeats_the_file():
    head = sp.get_sensor("mid40-replay").heads[0]
    with pytest.warns(sp.PatternLoopWarning, match="loops past the file's end"):
        looped = sp.head_shots(head, 4.0, 4.1)
    np.testing.assert_array_equal(looped.dirs, sp.head_shots(head, 0.0, 0.1).dirs)


def test_density_x2_interpolates_between_file_shots():
    head = sp.get_sensor("mid40-replay").heads[0]
    shots = sp.head_shots(head, 1.0, 1.01, density=2.0)
    assert len(shots) == 2_000
    on_file, between = shots.dirs[1::2], shots.dirs[0::2]
    mid = (on_file[:-1].astype(np.float64) + on_file[1:]) / 2
    # odd shots fall on the file's shots; even ones halfway between their neighbours
    assert angle_between_deg(between[1:], mid).max() < 1e-3


def test_livox_csv_layout_loads_like_the_npz(tmp_path):
    pattern = load_pattern_file("mid40")
    azimuth, zenith = livox_angles(pattern.dirs[:1000])
    path = tmp_path / "mid40.csv"
    rows = np.column_stack([pattern.t_s[:1000], azimuth, zenith])
    np.savetxt(path, rows, delimiter=",", header="time,azimuth,zenith", comments="", fmt="%.10f")
    head = sp.HeadSpec("replay", {"file": str(path)})
    shots = sp.head_shots(head, 0.0, 0.01)
    assert len(shots) == 1000
    assert angle_between_deg(shots.dirs, pattern.dirs[:1000]).max() < 1e-4


def test_missing_file_is_named():
    with pytest.raises(ValueError, match=r"pattern file not found: .*nowhere\.csv"):
        sp.head_shots(sp.HeadSpec("replay", {"file": "/nowhere.csv"}), 0.0, 0.1)


def test_official_files_ship_with_the_project_and_the_environment_overrides(tmp_path, monkeypatch):
    monkeypatch.delenv("SIMGEN_LIVOX_DIR", raising=False)
    shipped = resolve("mid70")
    assert shipped.parent == Path(sp.__file__).resolve().parent / "reference"
    (tmp_path / shipped.name).symlink_to(shipped)
    monkeypatch.setenv("SIMGEN_LIVOX_DIR", str(tmp_path))
    assert resolve("mid70") == tmp_path / shipped.name
    with pytest.raises(ValueError, match=r"mid40_official_4s.npz \(set by \$SIMGEN_LIVOX_DIR\)"):
        resolve("mid40")
