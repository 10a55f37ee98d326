"""Scenario files: YAML validated by a pydantic schema.

A scenario says what to simulate. Unknown keys, wrong types and out-of-range values are
rejected with one line naming the field (`load_scenario` raises `UserError`).
Sections: motion, scene, custom_sensors, sensors, scan, noise, dataset.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

import scan_patterns
from simgen.validation import read_yaml, validate


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class MotionConfig(_Strict):
    """How the Google Research Football engine plays and what is captured."""

    level: str = Field(
        "11_vs_11_stochastic",
        pattern=r"^[A-Za-z0-9_]+$",
        description="GRF level (scenario module in gfootball.scenarios); all players on built-in AI.",
    )
    frames: int = Field(100, ge=1, le=1_000_000, description="Frames captured, at capture_hz.")
    capture_hz: Literal[10, 20, 25, 50, 100] = Field(
        10, description="Keypoint samples per second of game time (engine steps are 10 Hz, physics 100 Hz)."
    )
    skip_s: float = Field(
        0.0, ge=0.0, le=3600.0, description="Game time played before capture starts, seconds."
    )
    left_difficulty: float | None = Field(
        None, ge=0.0, le=1.0, description="Built-in AI strength of the left team (default: the level's)."
    )
    right_difficulty: float | None = Field(
        None, ge=0.0, le=1.0, description="Built-in AI strength of the right team (default: the level's)."
    )


class SceneConfig(_Strict):
    """What stands on and around the pitch besides the humanoids and the ball."""

    goals: bool = Field(True, description="Both goals: posts, crossbar and net.")
    net_transmission: float = Field(0.7, ge=0.0, le=1.0, description="Fraction of rays a goal net lets through.")
    surroundings: bool = Field(False, description="Advertising boards round the pitch and a stand behind the far touchline.")


class SensorPose(_Strict):
    """Where a sensor stands in the pitch frame: metres, and degrees (roll about x, pitch about y
    (positive: looking up), yaw about z (0: looking along +x, 90: along +y)), applied yaw, pitch, roll."""

    x: float = Field(0.0, ge=-200, le=200)
    y: float = Field(-36.0, ge=-200, le=200)
    z: float = Field(4.0, ge=0.0, le=100)
    roll: float = Field(0.0, ge=-180, le=180)
    pitch: float = Field(-10.0, ge=-90, le=90)
    yaw: float = Field(90.0, ge=-360, le=360)


class SensorConfig(_Strict):
    """One LiDAR: a scan-pattern preset (see `simgen pattern --help`, or `custom_sensors`) at a pose."""

    name: str = Field("mid100", pattern=r"^[A-Za-z0-9_.-]+$")
    preset: str = Field("mid100-risley", description="Sensor preset of scan_patterns.")
    pose: SensorPose = SensorPose()


class ScanConfig(_Strict):
    """How the sensors' shots are grouped into frames."""

    frame_rate_hz: float = Field(10.0, gt=0.0, le=100.0, description="Frames per second.")
    density: float = Field(1.0, gt=0.0, le=64.0, description="Shots per second as a multiple of the real sensor's.")
    sweeps_per_frame: int = Field(1, ge=1, le=16, description="Sweeps merged into one frame (the paper: two 20 Hz sweeps).")
    frames: int | None = Field(None, ge=1, le=1_000_000, description="Frames per clip (default: as many as the motion allows).")


class DatasetConfig(_Strict):
    """What `simgen generate` writes."""

    clips: int = Field(1, ge=1, le=100_000, description="Clips: motion sequences of one seed each.")
    format: Literal["parquet", "kitti", "kitti_tracking", "openpcdet", "mcap"] = Field("parquet", description="Dataset layout.")
    kitti_images: bool = Field(
        False, description="kitti: also write placeholder training/image_2 PNGs (the virtual camera's size, blank), "
        "which OpenPCDet's KITTI info generation opens."
    )

    @model_validator(mode="after")
    def _images_for_kitti(self) -> "DatasetConfig":
        if self.kitti_images and self.format != "kitti":
            raise ValueError(f"dataset.kitti_images: placeholder images are for format kitti, not {self.format}")
        return self


class NoiseConfig(_Strict):
    """The sensor's imperfections (section `noise`; used by simgen.render.noise). Defaults: the Livox Mid-40 datasheet."""

    range_sigma_m: float = Field(0.02, ge=0, le=1, description="Gaussian range noise, 1 sigma, metres.")
    angle_sigma_deg: float = Field(0.03, ge=0, le=1, description="Gaussian direction noise per axis across the beam, 1 sigma, degrees.")
    divergence_deg: tuple[float, float] = Field(
        (0.03, 0.28), description="Full beam divergence (horizontal, vertical), degrees."
    )
    subrays: int = Field(
        1, ge=1, le=16, description="Rays per shot spread over the beam footprint; the nearest return wins (1: off)."
    )
    min_range_m: float = Field(1.0, ge=0, le=50, description="Returns nearer than this are lost, metres.")
    max_range_at_10pct_m: float = Field(
        90.0, gt=0, le=1000, description="Detection range at 10 % reflectivity; it grows as sqrt(reflectivity), metres."
    )
    dropout: float = Field(0.0, ge=0, lt=1, description="Probability that a return is lost at random.")
    enabled: bool = Field(True, description="False: exact ranges and directions, no dropout (range limits still apply).")


class Scenario(_Strict):
    """A whole scenario file."""

    name: str = Field(..., pattern=r"^[A-Za-z0-9_.-]+$", description="Short name, used in outputs.")
    description: str = ""
    seed: int = Field(0, ge=0, lt=2**31, description="Seed of every random choice (engine included).")
    motion: MotionConfig = MotionConfig()
    scene: SceneConfig = SceneConfig()
    custom_sensors: list[dict] = Field(
        default_factory=list,
        max_length=64,
        description="Sensor presets of this scenario: {name, description, heads: [{like: PRESET | pattern: risley|rose|replay, "
        "params, shots_per_s, fov_deg, yaw_deg, pitch_deg, time_offset_s}]} (scan_patterns.make_sensor).",
    )
    sensors: list[SensorConfig] = Field(default_factory=lambda: [SensorConfig()], min_length=1, max_length=16)
    scan: ScanConfig = ScanConfig()
    noise: NoiseConfig = NoiseConfig()
    dataset: DatasetConfig = DatasetConfig()

    @field_validator("custom_sensors")
    @classmethod
    def _custom_sensors_are_sensors(cls, specs: list[dict]) -> list[dict]:
        for spec in specs:
            scan_patterns.make_sensor(spec)  # raises ValueError naming the problem
        return specs

    def sensor_specs(self) -> list[scan_patterns.SensorSpec]:
        """The scan-pattern sensor of each entry of `sensors`: a custom one, else a registered preset."""
        custom = {spec.name: spec for spec in map(scan_patterns.make_sensor, self.custom_sensors)}
        return [custom[s.preset] if s.preset in custom else scan_patterns.get_sensor(s.preset) for s in self.sensors]

    @model_validator(mode="after")
    def _presets_exist(self) -> "Scenario":
        known = set(scan_patterns.sensor_names()) | {spec["name"] for spec in self.custom_sensors}
        for i, sensor in enumerate(self.sensors):
            if sensor.preset not in known:
                raise ValueError(f"sensors.{i}.preset: unknown sensor preset '{sensor.preset}' (known: {', '.join(sorted(known))})")
        return self

    @model_validator(mode="after")
    def _motion_covers_the_frames(self) -> "Scenario":
        motion_s = (self.motion.frames - 1) / self.motion.capture_hz
        if self.scan.frames is not None and self.scan.frames / self.scan.frame_rate_hz > motion_s + 1e-9:
            raise ValueError(
                f"scan.frames: {self.scan.frames} frames at {self.scan.frame_rate_hz:g} Hz need "
                f"{self.scan.frames / self.scan.frame_rate_hz:.2f} s of motion, motion.frames gives {motion_s:.2f} s"
            )
        return self


def parse_scenario(data: object, source: str = "scenario") -> Scenario:
    """Validate a parsed YAML document; raise `UserError` naming the first bad field."""
    return validate(Scenario, data, source)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    return parse_scenario(read_yaml(path, "scenario"), str(path))
