"""The `rotors` models against Livox's tables: the Mid-360's whole table (shipped), HAP's 0.5 s excerpt;
and the fit."""

from __future__ import annotations

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns import fit_rotors, rotors
from scan_patterns.shots import angle_between_deg, dirs_from_angles

HEAD = sp.get_sensor("mid360-rotors").heads[0]
TIMES_S = (0.1, 0.5, 1.0, 4.0)


@pytest.fixture(scope="module")
def pair():
    return sp.head_shots(HEAD, 0.0, 4.0), sp.file_shots("mid360")


def test_every_shot_within_the_tables_rounding(pair):
    """The table gives azimuths in 0.01 deg steps (5-6 digits): rounding alone is up to 0.005 deg."""
    model, reference = pair
    assert sp.official_table(HEAD) == "mid360" and len(model) == len(reference) == 800_000
    np.testing.assert_array_equal(model.line, reference.line)
    error_deg = angle_between_deg(model.dirs, reference.dirs)
    print(f"mid360-rotors vs the table: max {error_deg.max():.2e} deg, rms {np.sqrt(np.mean(error_deg**2)):.2e} deg")
    assert error_deg.max() < 0.01 and np.sqrt(np.mean(error_deg**2)) < 0.003


@pytest.mark.parametrize("cell_deg", sp.CELL_SIZES_DEG)
def test_coverage_within_half_a_point_at_0_1_to_4_s(pair, cell_deg):
    model, reference = pair
    mine = sp.coverage_curve(model, HEAD.field_of_view, TIMES_S, cell_deg)
    theirs = sp.coverage_curve(reference, HEAD.field_of_view, TIMES_S, cell_deg)
    assert np.all(np.abs(mine - theirs) <= 0.005)


def test_no_seam_at_4_s_and_no_4_s_period():
    around = sp.head_shots(HEAD, 3.99, 4.01)
    step = angle_between_deg(around.dirs[4:], around.dirs[:-4])  # each laser's own consecutive shots
    assert step.max() < 1.5 * np.median(step)  # the looped table jumps 69-74 deg here
    first, second = sp.head_shots(HEAD, 0.0, 0.1), sp.head_shots(HEAD, 4.0, 4.1)
    assert np.median(angle_between_deg(first.dirs, second.dirs)) > 1.0


def test_stored_rates_are_whole_degrees_per_second_and_hertz():
    """-65,670 deg/s and 10 Hz: fit_rotors returns them to 1e-6 Hz from the table alone."""
    fit = rotors.load("mid360")
    assert len(fit.elevation) == len(fit.azimuth) == rotors.FITS["mid360"] == HEAD.lasers
    f1, f2 = fit.rates_hz
    assert f1 == pytest.approx(-65_670.0 / 360.0, abs=1e-6) and f2 == pytest.approx(10.0, abs=1e-6)


def test_fit_on_one_second_finds_the_rates_and_a_map_that_holds_for_the_next_three():
    reference = sp.file_shots("mid360")
    first = reference.t_s <= 1.0
    result = fit_rotors.fit(reference.t_s[first], reference.dirs[first], reference.line[first], (3, 12))
    np.testing.assert_allclose(result.rates_hz, rotors.load("mid360").rates_hz, atol=1e-5)
    later = ~first
    azimuth, elevation = rotors.angles(result, reference.t_s[later], reference.line[later])
    error_deg = angle_between_deg(dirs_from_angles(azimuth, elevation), reference.dirs[later])
    assert error_deg.max() < 0.02


@pytest.mark.parametrize("table", rotors.FITS)
@pytest.mark.parametrize("t0_s", [0.0, 1000.0])
def test_angles_are_the_fourier_sums_of_the_docstring(table, t0_s):
    """The compiled sums (cos and sin of k delta by rotation) against exp(i (m theta1 + k delta)) term by term,
    to 1e-12 rad (6e-11 deg), near 0 and 1000 s on."""
    fit = rotors.load(table)
    t_s = t0_s + np.arange(1, 20_001) / 200_000.0
    line = np.arange(len(t_s)) % len(fit.elevation)
    theta1, delta = (2 * np.pi * (rate_hz * t_s % 1.0) for rate_hz in fit.rates_hz)  # turns reduced first
    orders, terms = fit.elevation.shape[1:]
    phase = np.exp(1j * (np.arange(orders)[:, None] * theta1[:, None, None]
                         + (np.arange(terms) - terms // 2) * delta[:, None, None]))
    elevation = np.einsum("nmk,nmk->n", fit.elevation[line], phase).real
    swing = np.einsum("nmk,nmk->n", fit.azimuth[line], phase).real
    azimuth, model_elevation = rotors.angles(fit, t_s, line)
    np.testing.assert_allclose(model_elevation, elevation, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (azimuth - fit.turns * theta1 - swing))), 0.0, rtol=0, atol=1e-12)


HAP = sp.get_sensor("hap-rotors").heads[0]
HAP_TIMES_S = (0.1, 0.25, 0.49)  # the shipped excerpt holds 0.49999 s
HAP_COVERAGE_POINTS = (0.5, 0.5, 2.5)  # per time: the round robin misses the table's uneven sampling by 2.2 at 0.49 s


@pytest.fixture(scope="module")
def hap_pair():
    reference = sp.file_shots("hap")
    return sp.head_shots(HAP, 0.0, reference.t1_s), reference


def test_hap_fires_as_the_driver_numbers_and_misses_the_table_by_its_rows_timing(hap_pair):
    """The preset fires laser (k - 1) mod 6 evenly at 452 kHz. The table's rows, their lasers told by
    elevation, lie on the map's paths but not at their rows' times (docs/scan_patterns.md): 1.7 deg rms."""
    model, reference = hap_pair
    assert sp.official_table(HAP) == "hap" and len(model) == len(reference) == 225_996
    np.testing.assert_allclose(model.t_s, reference.t_s, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(model.line, np.arange(len(model)) % 6)
    line = fit_rotors.elevation_lines(np.arcsin(reference.dirs[:, 2].astype(np.float64)), 6)
    azimuth, elevation = rotors.angles(rotors.load("hap"), reference.t_s, line)
    error_deg = angle_between_deg(dirs_from_angles(azimuth, elevation), reference.dirs)
    print(f"hap-rotors vs the excerpt: max {error_deg.max():.2f} deg, rms {np.sqrt(np.mean(error_deg**2)):.2f} deg")
    assert error_deg.max() < 4.0 and np.sqrt(np.mean(error_deg**2)) < 1.5  # measured: 3.94, 1.47


def test_hap_lasers_by_elevation_are_the_drivers_until_row_413_and_balanced_after():
    reference = sp.file_shots("hap")
    line = fit_rotors.elevation_lines(np.arcsin(reference.dirs[:, 2].astype(np.float64)), 6)
    np.testing.assert_array_equal(line[:413], reference.line[:413])
    assert line[413] != reference.line[413]  # the first row out of the drivers' order
    assert np.ptp(np.bincount(line)) < 0.002 * len(line) / 6


@pytest.mark.parametrize("cell_deg", sp.CELL_SIZES_DEG)
def test_hap_coverage_of_the_excerpt_within_half_a_point_to_0_25_s_and_2_5_at_0_49_s(hap_pair, cell_deg):
    model, reference = hap_pair
    mine = sp.coverage_curve(model, HAP.field_of_view, HAP_TIMES_S, cell_deg)
    theirs = sp.coverage_curve(reference, HAP.field_of_view, HAP_TIMES_S, cell_deg)
    assert np.all(np.abs(mine - theirs) * 100 <= HAP_COVERAGE_POINTS)


def test_hap_target_points_within_qa_tolerance_density_within_6_percent(hap_pair):
    """QA's 3 % on density is missed (5.6 %): the table fires the laser nearest the horizon more often
    than round robin does, the preset fires as the driver numbers (docs/scan_patterns.md)."""
    model, reference = hap_pair
    c = sp.compare(model, reference, HAP.field_of_view, ("hap-rotors", "hap"), cells_deg=())
    mine, theirs = c.target_points
    assert c.max_density_rel_diff <= 0.06 and np.max(np.abs(mine - theirs) / theirs) <= 0.05


def test_hap_runs_on_past_the_tables_2_32_s_without_a_seam():
    """Each laser's step across 2.32 s is no larger than its steps within the table (the looped table: 34 deg)."""
    inside, around = sp.head_shots(HAP, 0.0, 0.1), sp.head_shots(HAP, 2.3, 2.34)
    step = angle_between_deg(around.dirs[6:], around.dirs[:-6])  # each laser's own consecutive shots
    assert step.max() <= angle_between_deg(inside.dirs[6:], inside.dirs[:-6]).max()


def test_retiming_moves_shots_back_to_where_the_map_draws_them():
    """Shots drawn by the HAP's map at times off by a wander of up to 100 us: three rounds of
    `fit_rotors._retimed` find their true times to 0.1 us, at most 50 us a round."""
    fit = rotors.load("hap")
    t_s = np.arange(1, 45_201) / 452_000.0
    line = np.arange(len(t_s)) % 6
    azimuth, elevation = rotors.angles(fit, t_s, line)
    stamped = t_s + 100e-6 * np.sin(2 * np.pi * 10.0 * t_s)
    first = fit_rotors._retimed(fit, stamped, azimuth, elevation, line)
    assert np.abs(first - stamped).max() <= fit_rotors.RETIME_STEP_S + 1e-12
    times = first
    for _ in range(2):
        times = fit_rotors._retimed(fit, times, azimuth, elevation, line)
    assert np.abs(times - t_s).max() < 1e-7
