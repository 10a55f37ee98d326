"""The Risley presets fitted to Livox's tables (the Mid-40's: test_scan_patterns_risley.py) against the
shipped files: shot for shot,
coverage, laser numbering, and the fit that found their parameters."""

from __future__ import annotations

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns import fit_risley, risley
from scan_patterns.shots import angle_between_deg

PRESETS = {"avia": "avia-risley", "tele": "tele15-risley", "horizon": "horizon-risley", "mid70": "mid70-risley"}
COVERAGE_TIMES_S = (0.1, 0.25, 0.5)  # the excerpts hold 0.5 s (Mid-70: 4 s)


@pytest.fixture(scope="module", params=PRESETS)
def pair(request):
    """(table name, the preset's head, its shots over the excerpt, the excerpt's shots)."""
    head = sp.get_sensor(PRESETS[request.param]).heads[0]
    reference = sp.file_shots(request.param)
    return request.param, head, sp.head_shots(head, 0.0, reference.t1_s), reference


def test_every_shot_within_3e_5_degrees_of_the_table_with_its_laser(pair):
    name, head, model, reference = pair
    assert sp.official_table(head) == name
    assert len(model) == len(reference)
    np.testing.assert_allclose(model.t_s, reference.t_s, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(model.line, reference.line)
    error_deg = angle_between_deg(model.dirs, reference.dirs)
    print(
        f"{PRESETS[name]} vs the shipped {name} table, {len(model):,} shots: max {error_deg.max():.2e} deg, rms "
        f"{np.sqrt(np.mean(error_deg**2)):.2e} deg"
    )
    assert error_deg.max() < 3e-5  # the float32 copy's precision, about 1e-5 deg


@pytest.mark.parametrize("cell_deg", sp.CELL_SIZES_DEG)
def test_coverage_within_half_a_point_of_the_table(pair, cell_deg):
    _, head, model, reference = pair
    mine = sp.coverage_curve(model, head.field_of_view, COVERAGE_TIMES_S, cell_deg)
    theirs = sp.coverage_curve(reference, head.field_of_view, COVERAGE_TIMES_S, cell_deg)
    assert np.all(np.abs(mine - theirs) <= 0.005)


def test_fast_generator_agrees_with_the_float64_reference_far_from_t0(pair):
    """Round by round on the shot clock (one prism position per round of lasers), 1000 s on."""
    _, head, _, _ = pair
    params = head.model
    shots = sp.head_shots(head, 1000.0, 1000.02)
    rounds = risley.round_times(shots.t_s, shots.line, head.shots_per_s)
    exact = risley.directions_exact(params, rounds, shots.line)
    assert angle_between_deg(shots.dirs, exact).max() < 1e-5


def _fit_returns_the_stored_optics(name: str, stride: int, rate_hz: float) -> None:
    """fit_risley on every `stride`-th shot of the shipped table `name`, from its spectrum alone."""
    reference, stored = sp.file_shots(name), risley.FITTED[name]
    take = slice(None, None, stride)
    result = fit_risley.fit(reference.t_s[take], reference.dirs[take], stored, reference.line[take], rate_hz)
    p = result.params
    print(
        f"{name}: fit on {len(reference.t_s[take])} shots, max {result.max_error_deg:.2e} deg, rms "
        f"{result.rms_error_deg:.2e} deg"
    )
    assert result.max_error_deg < 3e-5
    np.testing.assert_allclose(p.wedge_deg, stored.wedge_deg, atol=1e-3)
    np.testing.assert_allclose(p.indices, stored.indices, atol=1e-4)
    np.testing.assert_allclose(p.rpm, stored.rpm, atol=1e-2)
    np.testing.assert_allclose(p.lasers_deg, stored.lasers_deg, atol=1e-3)


def test_fit_recovers_avias_parameters_from_the_excerpt_alone():
    """Six lasers, all started on the boresight; a prime stride takes every laser (1,238 shots of
    0.5 s, about 30 CPU seconds)."""
    _fit_returns_the_stored_optics("avia", 97, 240_000.0)


def test_fit_finds_the_mid70s_face_order_and_glass_from_its_file():
    """The Mid-70's prisms meet the beam wedged face first, then flat face first (the Avia's order):
    the fit returns the stored optics (2,011 shots, about 5 CPU seconds)."""
    _fit_returns_the_stored_optics("mid70", 199, 100_000.0)
