"""Livox's official tables of Avia, Horizon, Tele-15, HAP and Mid-360: the shipped excerpts, their
replay presets (shot times, lasers, seams) and their QA, against the excerpts themselves."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns.livox_tables import TABLES
from scan_patterns.replay import load_pattern_file
from scan_patterns.shots import angle_between_deg
from scan_patterns.write_tables import write_table
from simgen.cli import main

PRESETS = {
    "avia": "avia-replay",
    "horizon": "horizon-replay",
    "tele": "tele15-replay",
    "hap": "hap-replay",
    "mid360": "mid360-replay",
}


def _laser_steps(dirs: np.ndarray, lasers: int) -> np.ndarray:
    """(lasers, rows - 1) angle (deg) from each of a laser's rows to its next."""
    rows = len(dirs) // lasers * lasers
    per_laser = dirs[:rows].reshape(-1, lasers, 3)
    return np.stack([angle_between_deg(per_laser[1:, k], per_laser[:-1, k]) for k in range(lasers)])


@pytest.mark.parametrize("name", PRESETS)
def test_x1_replay_is_the_shipped_table_shot_for_shot_with_its_lasers(name):
    table, head = TABLES[name], sp.get_sensor(PRESETS[name]).heads[0]
    reference = sp.file_shots(name)
    assert len(reference) == table.excerpt_rows(table.excerpt_s) and len(reference) % table.lasers == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", sp.PatternLoopWarning)
        shots = sp.head_shots(head, 0.0, reference.t1_s)
    np.testing.assert_allclose(shots.t_s, np.arange(1, len(reference) + 1) / table.shots_per_s, rtol=0, atol=1e-12)
    assert angle_between_deg(shots.dirs, reference.dirs).max() < 2e-5  # float32 columns of float64 directions
    np.testing.assert_array_equal(shots.line, np.arange(len(shots)) % table.lasers)
    np.testing.assert_array_equal(shots.line, reference.line)


@pytest.mark.parametrize("name", PRESETS)
def test_row_i_is_laser_i_mod_lasers(name):
    """Each laser's own rows draw a smooth curve; rows of neighbouring lasers are far apart."""
    dirs = load_pattern_file(name).dirs
    lasers = TABLES[name].lasers
    own = np.median(_laser_steps(dirs, lasers))
    for other in range(1, lasers):
        assert np.median(angle_between_deg(dirs[other:], dirs[:-other])) > 1.5 * own
    smooth = _laser_steps(dirs, lasers).max(axis=1) / own
    if name == "hap":  # 5 % of HAP's rows come out of round-robin order: the file's own jumps
        assert np.all(smooth > 10)
    else:
        assert np.all(smooth < 1.5)


def test_elevation_signs_put_the_mid360_field_where_livox_says():
    """Mid-360: 360 x -7..52 deg (datasheet); its first shot at azimuth 268.99, zenith 37.838 (Livox's CSV)."""
    azimuth_deg, zenith_deg = sp.livox_angles(load_pattern_file("mid360").dirs)
    elevation = 90.0 - zenith_deg
    assert -7.3 < elevation.min() < -7.0 and 52.0 < elevation.max() < 52.3
    assert np.mod(azimuth_deg[0], 360.0) == pytest.approx(268.99, abs=1e-4) and zenith_deg[0] == pytest.approx(
        37.838, abs=1e-4
    )


def test_a_window_from_any_shot_continues_the_lasers_and_density_stays_on_a_laser():
    head = sp.get_sensor("avia-replay").heads[0]
    whole = sp.head_shots(head, 0.0, 0.02)
    later = sp.head_shots(head, 0.01, 0.02)
    np.testing.assert_array_equal(later.line, whole.line[-len(later):])
    np.testing.assert_array_equal(later.dirs, whole.dirs[-len(later):])
    doubled = sp.head_shots(head, 0.01, 0.02, density=2.0)
    steps = _laser_steps(doubled.dirs, 6)  # consecutive shots of one laser, half a file step apart
    assert np.median(steps) == pytest.approx(np.median(_laser_steps(whole.dirs, 6)) / 2, rel=0.05)
    assert steps.max() < 0.3


# The shipped tables' seams: Mid-360's whole table, HAP's 0.5 s excerpt (its whole table jumps 34 deg).
@pytest.mark.parametrize("name, seam_deg", [("mid360", 60.0), ("hap", 20.0)])
def test_past_the_table_it_loops_loudly_and_jumps_at_the_seam(name, seam_deg):
    head = sp.get_sensor(PRESETS[name]).heads[0]
    end = sp.file_shots(name).t1_s
    with pytest.warns(sp.PatternLoopWarning, match=re.escape(f"loops past the file's end ({end:g} s)")):
        around = sp.head_shots(head, end - 1e-4, end + 1e-4)
    seam = np.searchsorted(around.t_s, end + 1e-12)
    lasers = head.lasers
    jump = angle_between_deg(around.dirs[seam : seam + lasers], around.dirs[seam - lasers : seam])
    assert np.all(jump > seam_deg)
    np.testing.assert_array_equal(around.line[seam : seam + lasers], np.arange(lasers))  # laser 0 starts the loop again


def test_the_table_tool_refuses_another_source(tmp_path):
    (tmp_path / "avia.npy").write_bytes(b"not mujoco-lidar's table")
    with pytest.raises(ValueError, match=r"sha256 .*not mujoco-lidar 0\.3\.5's"):
        write_table(TABLES["avia"], tmp_path, tmp_path, full=False)
    assert [p.name for p in tmp_path.iterdir()] == ["avia.npy"]


@pytest.mark.parametrize("name", PRESETS)
def test_qa_passes_each_replay_preset_on_its_box(name, tmp_path, capsys):
    assert main(["qa", "--pattern", PRESETS[name], "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "PASS: 6 passed, 0 failed, 0 not applicable" in out
    report = (tmp_path / "report.md").read_text()
    assert f"| pass | {PRESETS[name]} head 0 | coverage, 0.2 deg cells |" in report
