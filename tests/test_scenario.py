"""Scenario files: the schema accepts ours and names the field of every mistake."""

from __future__ import annotations

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import scan_patterns as sp
from simgen.errors import UserError
from simgen.scenario import Scenario, load_scenario, parse_scenario
from tests.support import ROOT
from tests.support.processes import run_simgen


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_scenarios_are_valid(path):
    scenario = load_scenario(path)
    assert scenario.name == path.stem


@pytest.mark.parametrize(
    "document, field",
    [
        ({"name": "x", "motoin": {}}, "unknown key 'motoin'"),
        ({"name": "x", "motion": {"frames": -5}}, "'motion.frames'"),
        ({"name": "x", "motion": {"frames": "many"}}, "'motion.frames'"),
        ({"name": "x", "motion": {"capture_hz": 30}}, "'motion.capture_hz'"),
        ({"name": "x", "motion": {"levle": "a"}}, "unknown key 'motion.levle'"),
        ({"name": "x", "motion": {"left_difficulty": 1.5}}, "'motion.left_difficulty'"),
        ({"name": "x", "seed": -1}, "'seed'"),
        ({"name": "has space"}, "'name'"),
        ({"seed": 1}, "missing key 'name'"),
        ({"name": "x", "scan": {"frames": 200}}, "scan.frames: 200 frames at 10 Hz need 20.00 s of motion"),
        ({"name": "x", "scan": {"density": 0}}, "'scan.density'"),
        ({"name": "x", "scan": {"frame_rate_hz": 0}}, "'scan.frame_rate_hz'"),
        ({"name": "x", "noise": {"range_sigma_m": -0.1}}, "'noise.range_sigma_m'"),
        ({"name": "x", "sensors": [{"pose": {"pitch": 120}}]}, "'sensors.0.pose.pitch'"),
        ({"name": "x", "dataset": {"format": "las"}}, "'dataset.format'"),
        ({"name": "x", "sensors": [{"preset": "mid999"}]}, "sensors.0.preset: unknown sensor preset 'mid999'"),
        (
            {"name": "x", "custom_sensors": [{"name": "w", "heads": [{"like": "mid40-rose", "fov_deg": 200}]}]},
            "'custom_sensors.0.heads.0.fov_deg'",
        ),
        (
            {"name": "x", "custom_sensors": [{"name": "w", "heads": [{"pattern": "spiral"}]}]},
            "'custom_sensors.0.heads.0.pattern'",
        ),
        (["a", "list"], "expected a mapping"),
    ],
)
def test_bad_documents_name_the_field(document, field):
    with pytest.raises(UserError) as error:
        parse_scenario(document, "s.yaml")
    message = str(error.value)
    assert field in message and "\n" not in message


def _write(tmp_path, text: str):
    path = tmp_path / "scenario.yaml"
    path.write_text(text)
    return path


def test_validate_cli_typo_negative_frames_and_missing_file(tmp_path):
    typo = _write(tmp_path, "name: t\nmotion:\n  frmaes: 10\n")
    negative = tmp_path / "negative.yaml"
    negative.write_text("name: t\nmotion:\n  frames: -10\n")
    for path, expected in [
        (typo, "unknown key 'motion.frmaes'"),
        (negative, "'motion.frames': Input should be greater than or equal to 1"),
        (tmp_path / "missing.yaml", "no such scenario file"),
    ]:
        result = run_simgen("validate", path)
        assert result.returncode == 2, result
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and expected in lines[0], result.stderr
        assert "Traceback" not in result.stderr and result.stdout == ""


def test_custom_sensor_from_the_scenario():
    scenario = parse_scenario(
        {
            "name": "x",
            "custom_sensors": [
                {"name": "wide", "heads": [{"like": "mid40-rose", "fov_deg": 90, "shots_per_s": 50000}]}
            ],
            "sensors": [{"preset": "wide"}, {"preset": "mid40-risley", "name": "second"}],
        }
    )
    wide, mid40 = scenario.sensor_specs()
    assert wide.heads[0].fov_deg == 90 and wide.heads[0].shots_per_s == 50000
    assert mid40.name == "mid40-risley"


def test_the_shots_a_scenario_fires_have_one_home():
    """Shots per second and per frame, density included: what the scan's sensors fire (scenario_sensors) and
    what the detector's memory check expects of a frame (train.preflight)."""
    from simgen.scan.sensor import scenario_sensors
    from train.preflight import scenario_points_per_frame

    scenario = parse_scenario(
        {
            "name": "x",
            "custom_sensors": [{"name": "wide", "heads": [{"like": "mid40-rose", "shots_per_s": 50000}]}],
            "sensors": [{"preset": "wide"}, {"preset": "mid100-risley", "name": "second"}],
            "scan": {"density": 3.0, "frame_rate_hz": 20.0},
        }
    )
    assert scenario.sensor_shots_per_s() == [150_000.0, 3 * 300_000.0]
    assert scenario.shots_per_s() == sum(s.shots_per_s for s in scenario_sensors(scenario)) == 1_050_000.0
    assert scenario.shots_per_frame() == 52_500.0 == scenario_points_per_frame(scenario)
    over = {"name": "x", "sensors": [{"preset": "mid100-risley"}] * 16, "scan": {"density": 5.0}}
    with pytest.raises(UserError, match="fire 24,000,000 shots/s"):
        parse_scenario(over)


def test_custom_heads_from_the_fitted_models():
    """The Tele-15's replay head drawn by its fitted optics, an Avia turned 30 deg, a Mid-360 pitched up."""
    scenario = parse_scenario(
        {
            "name": "x",
            "custom_sensors": [{"name": "mix", "heads": [
                {"like": "tele15-replay", "pattern": "risley", "params": {"optics": "tele"}},
                {"like": "avia-risley", "yaw_deg": 30},
                {"like": "mid360-rotors", "pitch_deg": 10, "params": {"fit": "mid360"}},
            ]}],
            "sensors": [{"preset": "mix"}],
        }
    )
    (mix,) = scenario.sensor_specs()
    tele, avia, mid360 = mix.heads
    assert tele.model == sp.get_sensor("tele15-risley").heads[0].model and sp.official_table(tele) == "tele"
    assert avia.yaw_deg == 30 and avia.model.lasers == 6 and mid360.pattern == "rotors"
    with pytest.raises(UserError, match="params of a risley head: 'optics': Input should be 'mid40'"):
        parse_scenario(
            {
                "name": "x",
                "custom_sensors": [{"name": "m", "heads": [{"pattern": "risley", "params": {"optics": "hap"}}]}],
            }
        )


def test_malformed_yaml_is_one_line(tmp_path):
    with pytest.raises(UserError, match="malformed YAML at line 3"):
        load_scenario(_write(tmp_path, "name: t\nmotion: [unclosed\n"))


@settings(max_examples=200, deadline=None)
@given(
    st.dictionaries(
        st.sampled_from(["frames", "capture_hz", "skip_s", "level", "left_difficulty", "bogus"]),
        st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=True), st.text(max_size=5), st.none()),
        min_size=1,
    )
)
def test_any_motion_section_is_valid_or_one_line_error(motion):
    """Property: whatever the values, the schema either accepts them within range or names one field."""
    try:
        scenario = parse_scenario({"name": "p", "motion": motion})
    except UserError as error:
        assert "\n" not in str(error) and "motion" in str(error)
    else:
        assert isinstance(scenario, Scenario)
        assert scenario.motion.frames >= 1 and scenario.motion.skip_s >= 0
        assert parse_scenario(yaml.safe_load(yaml.safe_dump(scenario.model_dump()))) == scenario  # round-trips
