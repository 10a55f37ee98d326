"""Shot streams: continuous windows, density, frames of merged sweeps, Mid-100 counts and span."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import scan_patterns as sp
from scan_patterns.shots import angle_between_deg, livox_angles

MID100 = sp.get_sensor("mid100-risley")


@settings(max_examples=25, deadline=None)
@given(
    preset=st.sampled_from(["mid40-risley", "mid40-rose", "mid100-rose"]),
    t0=st.floats(0.0, 50.0),
    split=st.floats(0.0, 1.0),
    length=st.floats(1e-4, 0.02),
    density=st.sampled_from([0.5, 1.0, 1.7, 2.0]),
)
def test_consecutive_windows_continue_each_other_exactly(preset, t0, split, length, density):
    sensor = sp.get_sensor(preset)
    t1, tm = t0 + length, t0 + split * length
    whole = sp.shots(sensor, t0, t1, density)
    left, right = sp.shots(sensor, t0, tm, density), sp.shots(sensor, tm, t1, density)
    for h in range(len(sensor.heads)):
        joined = np.concatenate([left.t_s[left.head == h], right.t_s[right.head == h]])
        np.testing.assert_array_equal(joined, whole.t_s[whole.head == h])
        dirs = np.concatenate([left.dirs[left.head == h], right.dirs[right.head == h]])
        np.testing.assert_array_equal(dirs, whole.dirs[whole.head == h])
    assert np.all((whole.t_s > t0 - 1e-9) & (whole.t_s <= t1 + 1e-9))


@pytest.mark.parametrize("preset", ["mid40-risley", "mid40-rose", "mid100-risley"])
def test_same_inputs_give_identical_output(preset):
    a = sp.frame_shots(sp.get_sensor(preset), 7, 10.0, 1.5)
    b = sp.frame_shots(sp.get_sensor(preset), 7, 10.0, 1.5)
    np.testing.assert_array_equal(a.t_s, b.t_s)
    np.testing.assert_array_equal(a.dirs, b.dirs)


def test_rose_x2_has_twice_the_shots_and_consecutive_frames_share_none():
    from scipy.spatial import cKDTree

    rose = sp.get_sensor("mid40-rose")
    for k in range(3):
        x1, x2 = sp.frame_shots(rose, k, 10.0, 1.0), sp.frame_shots(rose, k, 10.0, 2.0)
        assert len(x2) == 2 * len(x1) == 20_000
    frames = [sp.frame_shots(rose, k, 10.0, 2.0) for k in range(3)]
    for a, b in zip(frames, frames[1:]):
        assert a.t_s.max() < b.t_s.min()  # no shot twice in time
        distance, _ = cKDTree(a.dirs).query(b.dirs)
        assert distance.min() > 1e-6  # and no direction repeated
        assert np.median(distance) > 1e-4


def test_rose_fills_its_field_of_view_and_no_more():
    rose = sp.get_sensor("mid40-rose")
    shots = sp.head_shots(rose.heads[0], 0.0, 1.0)
    off_axis = np.degrees(np.arccos(np.clip(shots.dirs[:, 0].astype(np.float64), -1, 1)))
    assert off_axis.max() <= 19.2 + 1e-3 and off_axis.max() > 19.1
    assert sp.coverage_curve(shots, 38.4, (1.0,))[0] > 0.5


@pytest.mark.parametrize("density, expected", [(1.0, 30_000), (2.0, 60_000)])
def test_mid100_frame_at_10_hz(density, expected):
    frame = sp.frame_shots(MID100, 3, 10.0, density)
    assert len(frame) == expected
    assert np.bincount(frame.head).tolist() == [expected // 3] * 3
    print(f"Mid-100 frame at 10 Hz, x{density:g}: {len(frame):,} shots")


def test_mid100_heads_span_98_4_by_38_4_degrees():
    assert MID100.fov_span_deg == pytest.approx((98.4, 38.4))
    assert MID100.shots_per_s == 300_000
    shots = sp.shots(MID100, 0.0, 1.0)
    azimuth, zenith = livox_angles(shots.dirs)
    span = (azimuth.max() - azimuth.min(), zenith.max() - zenith.min())
    print(f"Mid-100 shots over 1 s span {span[0]:.2f} x {span[1]:.2f} deg")
    assert span == pytest.approx((98.4, 38.4), abs=0.15)


def test_mid100_heads_are_yawed_and_run_on_their_own_clocks():
    frame = sp.frame_shots(MID100, 0)
    azimuth, _ = livox_angles(frame.dirs)
    centres = [np.median(azimuth[frame.head == h]) for h in range(3)]
    assert centres == pytest.approx([-30.0, 0.0, 30.0], abs=3.0)
    head_frames = [sp.head_shots(h, 0.0, 0.1) for h in MID100.heads]
    assert np.median(angle_between_deg(head_frames[0].dirs, head_frames[1].dirs)) > 1.0


def test_sweeps_merged_into_a_frame_are_labelled_in_time_order():
    frame = sp.frame_shots(sp.get_sensor("mid40-risley"), 5, frame_rate_hz=10.0, sweeps_per_frame=2)
    t0, t1 = sp.frame_window(5, 10.0)
    assert (frame.t0_s, frame.t1_s) == (t0, t1)
    assert np.bincount(frame.sweep).tolist() == [5_000, 5_000]
    assert frame.t_s[frame.sweep == 0].max() <= t0 + 0.05 + 1e-9 < frame.t_s[frame.sweep == 1].min()
    one_sweep = sp.frame_shots(sp.get_sensor("mid40-risley"), 5, frame_rate_hz=10.0)
    np.testing.assert_array_equal(one_sweep.dirs, frame.dirs)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_density_is_refused(bad):
    with pytest.raises(ValueError, match="density"):
        sp.shots(sp.get_sensor("mid40-rose"), 0.0, 0.1, bad)
