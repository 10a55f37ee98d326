"""The `risley` model against Livox's official Mid-40 file, its fit, and its continuation past 4 s."""

from __future__ import annotations

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns import fit_risley, risley
from scan_patterns.replay import load_pattern_file
from scan_patterns.shots import angle_between_deg

MID40_HEAD = sp.get_sensor("mid40-risley").heads[0]


@pytest.fixture(scope="module")
def official():
    return sp.file_shots("mid40")


@pytest.fixture(scope="module")
def model_4s():
    return sp.head_shots(MID40_HEAD, 0.0, 4.0)


def test_every_shot_within_2e_5_degrees_of_the_official_file(official, model_4s):
    """The README's 1e-5 degrees: measured 1.09e-5 at most (float32 output; the file's own precision)."""
    assert len(model_4s) == len(official) == 400_000
    np.testing.assert_allclose(model_4s.t_s, official.t_s, rtol=0, atol=1e-9)
    error_deg = angle_between_deg(model_4s.dirs, official.dirs)
    print(
        f"risley vs official Mid-40, 400,000 shots: max {error_deg.max():.2e} deg, rms "
        f"{np.sqrt(np.mean(error_deg**2)):.2e} deg"
    )
    assert error_deg.max() < 2e-5


@pytest.mark.parametrize("cell_deg", sp.CELL_SIZES_DEG)
def test_coverage_curve_within_one_point_of_the_official_file(official, model_4s, cell_deg):
    model = sp.coverage_curve(model_4s, 38.4, sp.COVERAGE_TIMES_S, cell_deg)
    reference = sp.coverage_curve(official, 38.4, sp.COVERAGE_TIMES_S, cell_deg)
    print(
        f"{cell_deg} deg cells: official {np.round(reference * 100, 2)} %, "
        f"max diff {np.abs(model - reference).max() * 100:.4f} points"
    )
    assert np.all(np.abs(model - reference) <= 0.01)
    assert np.all(np.diff(model) >= 0) and model[0] > 0


def test_beam_footprint_coverage_matches_too_and_exceeds_point_coverage(official, model_4s):
    model = sp.coverage_curve(model_4s, 38.4, footprint_deg=sp.BEAM_DIVERGENCE_DEG)
    reference = sp.coverage_curve(official, 38.4, footprint_deg=sp.BEAM_DIVERGENCE_DEG)
    assert np.all(np.abs(model - reference) <= 0.01)
    assert np.all(model >= sp.coverage_curve(model_4s, 38.4))


def test_fit_recovers_the_stored_parameters_from_the_file_alone():
    pattern = load_pattern_file("mid40")
    result = fit_risley.fit(pattern.t_s[::50], pattern.dirs[::50])
    p, stored = result.params, risley.MID40
    assert result.max_error_deg < 2e-5  # 1.03e-5 measured
    np.testing.assert_allclose(p.wedge_deg, stored.wedge_deg, atol=1e-3)
    np.testing.assert_allclose(p.index, stored.index, atol=1e-5)
    np.testing.assert_allclose(p.rpm, stored.rpm, atol=1e-3)
    phase_gap = np.angle(np.exp(1j * np.radians(np.subtract(p.phase_deg, stored.phase_deg))))
    np.testing.assert_allclose(np.degrees(phase_gap), 0.0, atol=1e-3)


def test_spectrum_shows_two_prisms_turning_opposite_ways():
    pattern = load_pattern_file("mid40")
    (hz1, _, _), (hz2, _, _) = fit_risley.spectral_lines(pattern.t_s, pattern.dirs)
    assert np.sign(hz1) != np.sign(hz2)
    assert sorted(abs(60 * np.array([hz1, hz2]))) == pytest.approx(sorted(np.abs(risley.MID40.rpm)), abs=20)


def test_snell_single_prism_deviation_matches_the_textbook_formula():
    # Beam at normal incidence on the flat face, out through the wedged face: deviation asin(n sin a) - a.
    a, n = np.radians(18.0), 1.5089
    s = risley._refract((1.0, 0.0, 0.0), (np.cos(a), np.sin(a), 0.0), n)
    deviation = np.arccos(s[0])
    assert deviation == pytest.approx(np.arcsin(n * np.sin(a)) - a, abs=1e-12)
    assert np.hypot(*s[1:]) ** 2 + s[0] ** 2 == pytest.approx(1.0, abs=1e-12)


def test_identical_prisms_aligned_are_a_parallel_plate_and_opposite_deviate_most():
    aligned = sp.RisleyParams(wedge_deg=(18.0, 18.0), index=1.5089, rpm=(0.0, 0.0), phase_deg=(30.0, 30.0))
    np.testing.assert_allclose(risley.directions_exact(aligned, np.array([0.0])), [[1.0, 0.0, 0.0]], atol=1e-12)
    opposite = sp.RisleyParams(wedge_deg=(18.0, 18.0), index=1.5089, rpm=(0.0, 0.0), phase_deg=(30.0, 210.0))
    edge = risley.directions_exact(opposite, np.array([0.0]))[0]
    single = np.arcsin(1.5089 * np.sin(np.radians(18.0))) - np.radians(18.0)
    assert np.degrees(np.arccos(edge[0])) > 1.9 * np.degrees(single)  # about twice one prism's deviation


@pytest.mark.parametrize("clock", ["even", "uneven"])
def test_fast_generator_agrees_with_the_float64_reference(clock):
    """Far from t = 0 (phases must stay exact), on a head's even shot clock (angles advanced by
    rotation between exact anchors) and on uneven times (every angle exact)."""
    if clock == "even":
        t = sp.head_shots(MID40_HEAD, 1000.0, 1000.2).t_s
    else:
        t = np.sort(np.random.default_rng(0).uniform(1000.0, 1001.0, 20_000))
    error = angle_between_deg(risley.directions(risley.MID40, t), risley.directions_exact(risley.MID40, t))
    assert error.max() < 1e-5


def test_keeps_covering_new_cells_after_4_s_while_the_looped_file_does_not():
    risley_16 = sp.head_shots(MID40_HEAD, 0.0, 16.0)
    with pytest.warns(sp.PatternLoopWarning):
        replay_16 = sp.head_shots(sp.get_sensor("mid40-replay").heads[0], 0.0, 16.0)
    times = (4.0, 8.0, 16.0)
    model = sp.coverage_curve(risley_16, 38.4, times, cell_deg=0.05)
    looped = sp.coverage_curve(replay_16, 38.4, times, cell_deg=0.05)
    print(
        f"0.05 deg cells at 4, 8, 16 s: risley {np.round(model * 100, 1)} %, looped file {np.round(looped * 100, 1)} %"
    )
    assert model[1] > model[0] + 0.1 and model[2] > model[1] + 0.1
    assert looped[2] == looped[0]


def test_no_4_s_period_and_no_seam_at_4_s():
    first, second = sp.head_shots(MID40_HEAD, 0.0, 4.0), sp.head_shots(MID40_HEAD, 4.0, 8.0)
    assert np.median(angle_between_deg(first.dirs, second.dirs)) > 1.0
    around = sp.head_shots(MID40_HEAD, 3.99, 4.01)
    step = angle_between_deg(around.dirs[1:], around.dirs[:-1])
    seam = np.searchsorted(around.t_s, 4.0)  # step from the shot at 4 s to the next
    assert step[seam] < 1.5 * np.median(step)
