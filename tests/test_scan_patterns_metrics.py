"""Fidelity metrics on shots placed by hand: coverage, radial density, target points, comparison."""

from __future__ import annotations

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns.shots import dirs_from_angles, dirs_from_off_axis, make_shots


def _at_projected(u_deg, v_deg):
    """Unit vectors whose azimuthal-equidistant coordinates are (u, v) degrees."""
    u, v = np.asarray(u_deg, np.float64), np.asarray(v_deg, np.float64)
    return dirs_from_off_axis(np.radians(np.hypot(u, v)), np.arctan2(v, u))


def _cell_centres(fov_deg, cell_deg):
    half = int(np.ceil(fov_deg / 2 / cell_deg)) + 2
    c = (np.arange(-half, half) + 0.5) * cell_deg
    u, v = np.meshgrid(c, c)
    inside = np.hypot(u, v) <= fov_deg / 2
    return u[inside], v[inside]


def test_coverage_counts_cells_hit_by_time_t():
    u, v = _cell_centres(10.0, 0.2)
    n = len(u)
    t = np.where(np.arange(n) < n // 4, 0.05, 0.15)  # a quarter of the cells by 0.1 s, all by 0.2 s
    shots = make_shots(t, _at_projected(u, v), 0.0, 0.3)
    np.testing.assert_allclose(sp.coverage_curve(shots, 10.0, (0.01, 0.1, 0.2), 0.2), [0.0, (n // 4) / n, 1.0])
    doubled = make_shots(np.r_[t, t], _at_projected(np.r_[u, u], np.r_[v, v]), 0.0, 0.3)
    np.testing.assert_allclose(sp.coverage_curve(doubled, 10.0, (0.2,), 0.2), [1.0])  # hits twice count once
    assert np.isnan(sp.coverage_curve(shots, 10.0, (0.5,), 0.2)[0])  # beyond the window


def test_a_box_field_of_view_counts_azimuth_elevation_cells_and_elevation_bands():
    box = (170.0, 180.0, -2.0, 2.0)  # 50 x 20 cells of 0.2 deg, across the azimuth's wrap at 180
    az, el = np.meshgrid(170.05 + 0.2 * np.arange(50), -1.95 + 0.2 * np.arange(20), indexing="ij")  # off the bin edges
    t = np.where(az.ravel() < 175.0, 0.05, 0.15)  # half the cells by 0.1 s, all by 0.2 s
    dirs = dirs_from_angles(np.radians(az.ravel()), np.radians(el.ravel()))
    shots = make_shots(t, dirs, 0.0, 0.3)
    np.testing.assert_allclose(sp.coverage_curve(shots, box, (0.01, 0.1, 0.2), 0.2), [0.0, 0.5, 1.0])
    outside = make_shots([0.1, 0.1], dirs_from_angles(np.radians([-170.0, 175.0]), np.radians([0.0, 3.0])), 0.0, 1.0)
    assert sp.coverage_curve(outside, box, (1.0,), 0.2)[0] == 0.0
    profile = sp.radial_density(shots, box, bin_deg=0.5)  # 8 elevation bands of 10 deg azimuth
    edges = np.arange(-2.0, 2.01, 0.5)
    per_band = np.histogram(el.ravel(), edges)[0]
    band_sr = np.radians(10.0) * np.diff(np.sin(np.radians(edges)))
    np.testing.assert_allclose(profile.off_axis_deg, np.arange(-1.75, 2.0, 0.5))
    np.testing.assert_allclose(profile.shots_per_sr_s, per_band / band_sr / 0.3)


def test_shots_outside_the_field_of_view_cover_nothing():
    shots = make_shots([0.1, 0.1], _at_projected([6.0, 0.0], [0.0, 7.0]), 0.0, 1.0)
    assert sp.coverage_curve(shots, 10.0, (1.0,), 0.2)[0] == 0.0


def test_beam_footprint_touches_the_cells_it_overlaps():
    u, _ = _cell_centres(10.0, 0.2)
    one = make_shots([0.01], _at_projected([0.1], [0.1]), 0.0, 1.0)  # centre of a cell
    point = sp.coverage_curve(one, 10.0, (1.0,), 0.2)[0]
    assert point == pytest.approx(1 / len(u))
    # 0.03 x 0.28 deg: 0.015 deg wide, 0.14 deg tall either side: reaches the cells above and below
    footprint = sp.coverage_curve(one, 10.0, (1.0,), 0.2, footprint_deg=sp.BEAM_DIVERGENCE_DEG)[0]
    assert footprint == pytest.approx(3 / len(u))


def test_radial_density_of_uniform_shots_is_flat():
    rng = np.random.default_rng(7)
    n, half_fov = 200_000, np.radians(19.2)
    cos_rho = rng.uniform(np.cos(half_fov), 1.0, n)  # uniform over the cap's solid angle
    dirs = dirs_from_off_axis(np.arccos(cos_rho), rng.uniform(0, 2 * np.pi, n))
    shots = make_shots(np.sort(rng.uniform(0, 2.0, n)), dirs, 0.0, 2.0)
    profile = sp.radial_density(shots, 38.4, bin_deg=2.0)
    expected = n / (2 * np.pi * (1 - np.cos(half_fov))) / 2.0
    assert profile.off_axis_deg[0] == pytest.approx(1.0)
    np.testing.assert_allclose(profile.shots_per_sr_s[:-1], expected, rtol=0.08)


def test_target_points_count_rays_through_the_rectangle_per_frame():
    off = np.radians(10.0)
    centre = np.array([np.cos(off), np.sin(off), 0.0]) * 50.0
    across = np.array([-np.sin(off), np.cos(off), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    points = [centre, centre + 0.24 * across + 0.89 * up, centre - 0.24 * across - 0.89 * up,  # on it
              centre + 0.26 * across, centre + 0.91 * up]  # just off it
    dirs = np.array(points) / np.linalg.norm(points, axis=1, keepdims=True)
    times = [0.05, 0.05, 0.25, 0.05, 0.25]
    shots = make_shots(times, dirs, 0.0, 0.3)
    assert sp.target_points_per_frame(shots, 50.0, 10.0, frame_rate_hz=10.0).tolist() == [2, 0, 1]
    assert sp.target_points_per_frame(shots, 50.0, -10.0, frame_rate_hz=10.0).tolist() == [0, 0, 0]


def test_comparison_of_a_pattern_with_itself_and_with_another():
    risley = sp.head_shots(sp.get_sensor("mid40-risley").heads[0], 0.0, 1.0)
    rose = sp.head_shots(sp.get_sensor("mid40-rose").heads[0], 0.0, 1.0)
    same = sp.compare(risley, risley, 38.4, ("risley", "risley"), times_s=(0.1, 1.0))
    assert all(d == 0 for d in same.max_coverage_diff.values())
    assert same.max_density_rel_diff == 0 and same.max_target_diff == 0
    other = sp.compare(risley, rose, 38.4, ("risley", "rose"), times_s=(0.1, 1.0))
    assert max(other.max_coverage_diff.values()) > 0 and other.max_density_rel_diff > 0
    table = other.markdown()
    assert "| metric | risley | rose | difference |" in table
    assert "coverage 0.2 deg cells, T = 1 s" in table and "points/frame on target at 100 m" in table
