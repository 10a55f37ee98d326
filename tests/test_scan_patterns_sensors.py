"""The sensor registry, custom heads, and the frame conventions (Livox azimuth/zenith, head yaw)."""

from __future__ import annotations

import numpy as np
import pytest

import scan_patterns as sp
from scan_patterns.shots import dirs_from_livox, head_rotation, livox_angles

PRESETS = [
    "mid40-risley",
    "mid40-rose",
    "mid40-replay",
    "mid70-replay",
    "mid100-risley",
    "mid100-rose",
    "avia-replay",
    "horizon-replay",
    "tele15-replay",
    "hap-replay",
    "mid360-replay",
    "avia-risley",
    "tele15-risley",
    "horizon-risley",
    "mid70-risley",
    "mid360-rotors",
    "hap-rotors",
]


def test_the_issue_presets_are_registered():
    assert set(PRESETS) <= set(sp.sensor_names())
    for name in PRESETS:
        sensor = sp.get_sensor(name)
        assert sensor.name == name and sensor.description


def test_unknown_sensor_names_the_known_ones():
    with pytest.raises(ValueError, match=r"^unknown sensor 'mid41'; known: .*mid40-risley"):
        sp.get_sensor("mid41")
    with pytest.raises(KeyError):  # a failed lookup, too
        sp.get_sensor("mid41")


def test_livox_angles_follow_gazebo_plugin_convention():
    # Livox's plugin: direction = Rz(azimuth) Ry(zenith - 90 deg) x.
    azimuth, zenith = np.array([10.0, -25.0, 0.0]), np.array([80.0, 100.0, 90.0])
    d = dirs_from_livox(azimuth, zenith)
    for row, az, zen in zip(d, np.radians(azimuth), np.radians(zenith)):
        rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
        p = zen - np.pi / 2
        ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
        np.testing.assert_allclose(row, rz @ ry @ [1, 0, 0], atol=1e-12)
    assert d[0, 1] > 0 and d[0, 2] > 0  # positive azimuth is left (+y), zenith < 90 is up
    np.testing.assert_allclose(livox_angles(d), (azimuth, zenith), atol=1e-9)


def test_head_yaw_and_pitch_turn_the_boresight():
    np.testing.assert_allclose(head_rotation(30.0, 0.0) @ [1, 0, 0], [np.cos(np.pi / 6), 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(
        head_rotation(0.0, 10.0) @ [1, 0, 0], [np.cos(0.1745329), 0, np.sin(0.1745329)], atol=1e-6
    )


def test_custom_sensor_from_a_mapping_extends_a_preset():
    sensor = sp.make_sensor(
        {
            "name": "tilted-pair",
            "heads": [
                {"like": "mid40-risley", "pitch_deg": -10.0, "shots_per_s": 50_000},
                {"pattern": "rose", "params": {"petals_per_frame": 12}, "yaw_deg": 40.0, "fov_deg": 30.0},
            ],
        }
    )
    assert sensor.shots_per_s == 150_000
    assert sensor.heads[0].model == sp.MID40
    assert sensor.heads[1].model.petals_per_frame == 12
    frame = sp.frame_shots(sensor, 0)
    assert np.bincount(frame.head).tolist() == [5_000, 10_000]
    _, zenith = livox_angles(frame.dirs[frame.head == 0])
    assert np.median(zenith) == pytest.approx(100.0, abs=3.0)  # pitched 10 deg down
    sp.register_sensor(sensor)
    assert sp.get_sensor("tilted-pair") is sensor
    with pytest.raises(ValueError, match="already registered"):
        sp.register_sensor(sensor)


def test_risley_parameters_override_the_fitted_ones():
    head = sp.make_head({"pattern": "risley", "params": {"rpm": [-6000, 4000]}})
    assert head.model.rpm == (-6000, 4000) and head.model.wedge_deg == sp.MID40.wedge_deg


@pytest.mark.parametrize(
    "spec, message",
    [
        ({"pattern": "spiral"}, "unknown pattern 'spiral'"),
        ({"pattern": "rose", "params": {"petals": 3}}, "rose: unknown parameter 'petals'"),
        ({"pattern": "rose", "shots_per_s": 0}, "shots_per_s must be positive"),
        ({"pattern": "rose", "fov_deg": 200}, r"fov_deg must be in \(0, 180\)"),
        ({"pattern": "replay", "params": {}}, "replay takes one parameter, 'file'"),
        ({"pattern": "risley", "params": {"index": 0.9}}, "refractive index must exceed 1"),
        ({"pattern": "risley", "params": {"optics": "mid41"}}, "risley: unknown optics 'mid41'; known: mid40"),
        ({"pattern": "risley", "lasers": 6}, "risley: the optics have 1 lasers, the head 6"),
        ({"pattern": "risley", "params": {"lasers_deg": [[0, 40]]}}, "lasers_deg holds 1 to 255"),
        ({"pattern": "risley", "params": {"rpm": [1000]}}, "risley: rpm has 1 values for 2 prisms"),
        ({"like": "mid360-rotors", "params": {"fit": "avia"}}, "rotors: no fit of table 'avia'; fitted: mid360, hap"),
        ({"like": "mid360-rotors", "lasers": 6}, "rotors: the optics have 4 lasers, the head 6"),
        ({"yaw_deg": 3}, "needs 'pattern'"),
        ({"like": "mid40-rose", "colour": "red"}, "unknown key 'colour'"),
        ({"pattern": "rose", "lasers": 0}, "lasers must be a whole number in 1..255"),
        ({"like": "mid360-replay", "fov_deg": 90.0}, "a head has one field of view"),
        ({"pattern": "rose", "fov_deg": None, "fov_box_deg": (-10, 10, -5, 5)}, "rose: draws a circular field of view"),
        ({"pattern": "risley", "fov_deg": None, "fov_box_deg": (10, -10, -5, 5)}, "fov_box_deg must be"),
    ],
)
def test_bad_heads_are_refused_in_one_line(spec, message):
    with pytest.raises(ValueError, match=message):
        sp.make_head(spec)
