"""Scenario files: YAML validated by a pydantic schema.

A scenario says what to simulate. Unknown keys, wrong types and out-of-range values are
rejected with one line naming the field (`load_scenario` raises `UserError`), and so is
everything a run would otherwise find out only mid-way: no frames to make, a frame that would
not fit in memory, a replay file outside the folders it may come from.
Sections: motion, scene, custom_sensors, sensors, scan, noise, dataset.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)

import scan_patterns
from scan_patterns.replay import OFFICIAL_FILES
from scan_patterns.risley import FITTED
from scan_patterns.rotors import FITS
from simgen.datasets.formats import FORMATS, format_limits, formats_allowing
from simgen.validation import Strict, one_line, read_yaml, validate

#: Colon-separated folders besides the scenario's own that a replay head's `file` may come from.
PATTERN_DIRS_ENV = "SIMGEN_PATTERN_DIRS"
#: Shots per second of all sensors together, density included (16 Mid-100 at x4: 19.2 million).
MAX_SHOTS_PER_S = 20_000_000
#: Memory one frame's rendering may need: shots x (BYTES_PER_SHOT + subrays x BYTES_PER_RAY).
MAX_FRAME_BYTES = 2 << 30
BYTES_PER_SHOT = 64  # the shot's ray: origin, direction, time, sensor, head
BYTES_PER_RAY = 256  # each cast ray's hit record, candidates and temporaries, rounded up


class MotionConfig(Strict):
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


class SceneConfig(Strict):
    """What stands on and around the pitch besides the humanoids and the ball."""

    goals: bool = Field(True, description="Both goals: posts, crossbar and net.")
    net_transmission: float = Field(0.7, ge=0.0, le=1.0, description="Fraction of rays a goal net lets through.")
    surroundings: bool = Field(
        False, description="Advertising boards round the pitch and a stand behind the far touchline."
    )


class SensorPose(Strict):
    """Where a sensor stands in the pitch frame: metres, and degrees (roll about x, pitch about y
    (positive: looking up), yaw about z (0: looking along +x, 90: along +y)), applied yaw, pitch, roll."""

    x: float = Field(0.0, ge=-200, le=200)
    y: float = Field(-36.0, ge=-200, le=200)
    z: float = Field(4.0, ge=0.0, le=100)
    roll: float = Field(0.0, ge=-180, le=180)
    pitch: float = Field(-10.0, ge=-90, le=90)
    yaw: float = Field(90.0, ge=-360, le=360)


class SensorConfig(Strict):
    """One LiDAR: a scan-pattern preset (see `simgen pattern --help`, or `custom_sensors`) at a pose."""

    name: str = Field("mid100", pattern=r"^[A-Za-z0-9_.-]+$")
    preset: str = Field("mid100-risley", description="Sensor preset of scan_patterns.")
    pose: SensorPose = SensorPose()


class ScanConfig(Strict):
    """How the sensors' shots are grouped into frames."""

    frame_rate_hz: float = Field(10.0, gt=0.0, le=100.0, description="Frames per second.")
    density: float = Field(1.0, gt=0.0, le=64.0, description="Shots per second as a multiple of the real sensor's.")
    sweeps_per_frame: int = Field(
        1, ge=1, le=16, description="Sweeps merged into one frame (the paper: two 20 Hz sweeps)."
    )
    frames: int | None = Field(
        None, ge=1, le=1_000_000, description="Frames per clip (default: as many as the motion allows)."
    )
    timing: Literal["sweep", "snapshot"] = Field(
        "sweep",
        description="sweep: each shot meets the scene at its own time, as a real Livox scans (fast players smear); "
        "snapshot: every shot of a frame meets the scene as it is at the frame's label time (the paper samples the "
        "engine's depth map once per frame), and every point carries that time.",
    )


class LabelsConfig(Strict):
    """How the boxes are drawn (simgen.labels.boxes)."""

    size: Literal["enclosing", "track"] = Field(
        "enclosing", description="enclosing: each box spans the body as posed at its label time (its length swings "
        "with the stride); track: each humanoid's length, width and height fixed at their medians over the clip (as "
        "annotators draw one size per person), the centre still from the pose.",
    )


class DatasetConfig(Strict):
    """What `simgen generate` writes."""

    clips: int = Field(1, ge=1, le=100_000, description="Clips: motion sequences of one seed each.")
    format: Literal[FORMATS] = Field(FORMATS[0], description="Dataset layout.")
    kitti_images: bool = Field(
        False, description="kitti: also write placeholder training/image_2 PNGs (the virtual camera's size, blank), "
        "which OpenPCDet's KITTI info generation opens."
    )

    @model_validator(mode="after")
    def _images_for_kitti(self) -> DatasetConfig:
        if self.kitti_images and not format_limits(self.format).placeholder_images:
            takers = " or ".join(formats_allowing(lambda limits: limits.placeholder_images))
            raise ValueError(f"dataset.kitti_images: placeholder images are for format {takers}, not {self.format}")
        return self


class NoiseConfig(Strict):
    """The sensor's imperfections (section `noise`; used by simgen.render.noise). Defaults: the Livox Mid-40
    datasheet."""

    range_sigma_m: float = Field(0.02, ge=0, le=1, description="Gaussian range noise, 1 sigma, metres.")
    angle_sigma_deg: float = Field(
        0.03, ge=0, le=1, description="Gaussian direction noise per axis across the beam, 1 sigma, degrees."
    )
    divergence_deg: tuple[Annotated[float, Field(ge=0, le=10)], Annotated[float, Field(ge=0, le=10)]] = Field(
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
    enabled: bool = Field(
        True, description="False: exact ranges and directions, no dropout (range limits still apply)."
    )

    @model_validator(mode="after")
    def _ranges_ordered(self) -> NoiseConfig:
        if self.min_range_m >= self.max_range_at_10pct_m:
            raise ValueError(
                f"min_range_m {self.min_range_m:g} m is not below max_range_at_10pct_m {self.max_range_at_10pct_m:g} m"
            )
        return self


class RisleyParamsConfig(Strict):
    """`params` of a `risley` head: a fitted set of optics (`optics`, default the Mid-40's) and
    overrides of its two prisms (scan_patterns.RisleyParams)."""

    optics: Literal[tuple(FITTED)] | None = Field(None, description="Livox table whose fitted optics to start from.")
    wedge_deg: tuple[Annotated[float, Field(gt=0, lt=45)], Annotated[float, Field(gt=0, lt=45)]] | None = None
    index: float | None = Field(None, gt=1.0, le=4.0, description="Refractive index of both prisms.")
    rpm: (
        tuple[Annotated[float, Field(ge=-100_000, le=100_000)], Annotated[float, Field(ge=-100_000, le=100_000)]] | None
    ) = None
    phase_deg: tuple[Annotated[float, Field(ge=-360, le=360)], Annotated[float, Field(ge=-360, le=360)]] | None = None


class RoseParamsConfig(Strict):
    """`params` of a `rose` head (scan_patterns.RoseParams)."""

    k: float | None = Field(None, gt=0, le=1000)
    petals_per_frame: float | None = Field(None, gt=0, le=10_000)
    frame_rate_hz: float | None = Field(None, gt=0, le=1000)
    theta0_hz: float | None = Field(None, ge=-1e6, le=1e6)


class RotorsParamsConfig(Strict):
    """`params` of a `rotors` head (scan_patterns.RotorParams)."""

    fit: Literal[tuple(FITS)] | None = Field(None, description="Livox table whose stored rotors fit to use.")


class ReplayParamsConfig(Strict):
    """`params` of a `replay` head: `file`, an official recording (mid40, mid70, avia, horizon, tele, hap,
    mid360) or a .npz / .csv file
    in the scenario's folder or a folder of $SIMGEN_PATTERN_DIRS."""

    file: str = Field(..., min_length=1, max_length=4096)

    @field_validator("file")
    @classmethod
    def _confined(cls, file: str, info: ValidationInfo) -> str:
        if file in OFFICIAL_FILES:
            return file
        base = (info.context or {}).get("scenario_dir")
        path = Path(file)
        if base is None and not path.is_absolute():
            raise ValueError(f"replay file '{file}': a relative path needs the scenario file's folder")
        resolved = (Path(base) / path if base is not None else path).resolve()
        if base is not None:  # read from a scenario file: only its folder and the listed ones
            allowed = [Path(base).resolve()] + [
                Path(d).resolve() for d in os.environ.get(PATTERN_DIRS_ENV, "").split(":") if d
            ]
            if not any(resolved == root or root in resolved.parents for root in allowed):
                raise ValueError(f"replay file '{file}' is outside the scenario's folder and ${PATTERN_DIRS_ENV}")
        if not resolved.is_file():
            raise ValueError(f"replay file '{file}': no such regular file")
        scan_patterns.replay.load_pattern_file(str(resolved))  # format and size; a ValueError never quotes the file
        return str(resolved)


_PARAMS = {
    "risley": RisleyParamsConfig,
    "rose": RoseParamsConfig,
    "replay": ReplayParamsConfig,
    "rotors": RotorsParamsConfig,
}


class HeadConfig(Strict):
    """One head of a custom sensor: a pattern (or `like`: a preset whose first head it starts from) and overrides."""

    like: str | None = Field(None, max_length=64, description="Sensor preset whose first head this one starts from.")
    pattern: Literal["risley", "rose", "replay", "rotors"] | None = None
    params: dict[str, object] | None = Field(
        None, description="The pattern's parameters (Risley, rose, replay or rotors)."
    )
    shots_per_s: float | None = Field(None, gt=0, le=MAX_SHOTS_PER_S, description="Shots per second at density x1.")
    fov_deg: float | None = Field(None, gt=0, lt=180, description="Full cone angle of the circular field of view.")
    yaw_deg: float | None = Field(None, ge=-360, le=360)
    pitch_deg: float | None = Field(None, ge=-90, le=90)
    time_offset_s: float | None = Field(None, ge=0, le=1e6, description="How far ahead the head's pattern clock runs.")
    lasers: int | None = Field(
        None, ge=1, le=255, description="Lasers taking turns: shot k fires laser (k - 1) mod lasers."
    )

    @field_validator("like")
    @classmethod
    def _preset(cls, like: str | None) -> str | None:
        if like is not None and like not in scan_patterns.sensor_names():
            raise ValueError(f"unknown sensor preset '{like}' (known: {', '.join(scan_patterns.sensor_names())})")
        return like

    @field_validator("params", mode="before")
    @classmethod
    def _params_mapping(cls, params: object) -> object:
        if params is not None and not isinstance(params, dict):
            raise ValueError("params must be a mapping of the pattern's parameters")
        return params

    @model_validator(mode="after")
    def _pattern_params(self, info: ValidationInfo) -> HeadConfig:
        if self.like is None and self.pattern is None:
            raise ValueError("a head needs 'pattern' (risley, rose, replay or rotors) or 'like' (a sensor preset)")
        pattern = self.pattern or scan_patterns.get_sensor(self.like).heads[0].pattern
        if self.params is not None:
            try:
                typed = _PARAMS[pattern].model_validate(self.params, context=info.context)
            except ValidationError as error:
                raise ValueError(f"params of a {pattern} head: {one_line(error)}") from None
            object.__setattr__(self, "params", typed.model_dump(exclude_none=True))
        elif pattern == "replay" and self.like is None:
            raise ValueError("a replay head needs params: {file: mid40 | mid70 | avia | ... | PATH}")
        return self

    @model_serializer(mode="wrap")
    def _without_unset(self, handler):
        return {key: value for key, value in handler(self).items() if value is not None}


class CustomSensorConfig(Strict):
    """A sensor preset of this scenario (scan_patterns.make_sensor): a name no built-in preset has, and its heads."""

    name: str = Field(..., pattern=r"^[A-Za-z0-9_.-]+$", max_length=64)
    description: str = Field("", max_length=1000)
    heads: list[HeadConfig] = Field(..., min_length=1, max_length=32)

    @field_validator("name")
    @classmethod
    def _not_a_preset(cls, name: str) -> str:
        if name in scan_patterns.sensor_names():
            raise ValueError(f"'{name}' is a built-in sensor preset; give the custom sensor another name")
        return name

    def spec(self) -> scan_patterns.SensorSpec:
        return scan_patterns.make_sensor(self.model_dump())


class Scenario(Strict):
    """A whole scenario file."""

    name: str = Field(..., pattern=r"^[A-Za-z0-9_.-]+$", max_length=128, description="Short name, used in outputs.")
    description: str = Field("", max_length=10_000)
    seed: int = Field(0, ge=0, lt=2**31, description="Seed of every random choice (engine included).")
    motion: MotionConfig = MotionConfig()
    scene: SceneConfig = SceneConfig()
    custom_sensors: list[CustomSensorConfig] = Field(
        default_factory=list,
        max_length=64,
        description="Sensor presets of this scenario: {name, description, heads: "
        "[{like: PRESET | pattern: risley|rose|replay, params, shots_per_s, fov_deg, yaw_deg, pitch_deg, "
        "time_offset_s}]} (scan_patterns.make_sensor).",
    )
    sensors: list[SensorConfig] = Field(default_factory=lambda: [SensorConfig()], min_length=1, max_length=16)
    scan: ScanConfig = ScanConfig()
    noise: NoiseConfig = NoiseConfig()
    labels: LabelsConfig = LabelsConfig()
    dataset: DatasetConfig = DatasetConfig()

    @field_validator("custom_sensors")
    @classmethod
    def _custom_sensors_are_sensors(cls, sensors: list[CustomSensorConfig]) -> list[CustomSensorConfig]:
        names = [sensor.name for sensor in sensors]
        for i, sensor in enumerate(sensors):
            if names.index(sensor.name) != i:
                raise ValueError(f"two custom sensors are named '{sensor.name}'")
            try:
                sensor.spec()
            except (ValueError, TypeError) as error:  # what the pattern's own checks find
                raise ValueError(f"custom sensor '{sensor.name}': {' '.join(str(error).splitlines())[:200]}") from None
        return sensors

    def sensor_specs(self) -> list[scan_patterns.SensorSpec]:
        """The scan-pattern sensor of each entry of `sensors`: a custom one, else a registered preset."""
        custom = [sensor.model_dump() for sensor in self.custom_sensors]
        return [scan_patterns.find_sensor(sensor.preset, custom) for sensor in self.sensors]

    def sensor_shots_per_s(self) -> list[float]:
        """Shots per second each entry of `sensors` fires: its preset's, times scan.density."""
        return [spec.shots_per_s * self.scan.density for spec in self.sensor_specs()]

    def shots_per_s(self) -> float:
        """Shots per second of all sensors together, density included."""
        return sum(self.sensor_shots_per_s())

    def shots_per_frame(self) -> float:
        """Shots of all sensors in one frame (scan.frame_rate_hz), density included: the most points a frame holds."""
        return self.shots_per_s() / self.scan.frame_rate_hz

    def frames_per_clip(self) -> int:
        """Frames of each clip: `scan.frames`, else as many as the captured motion covers."""
        motion_s = (self.motion.frames - 1) / self.motion.capture_hz
        return self.scan.frames or math.floor(motion_s * self.scan.frame_rate_hz + 1e-9)

    @model_validator(mode="after")
    def _presets_exist(self) -> Scenario:
        known = set(scan_patterns.sensor_names()) | {sensor.name for sensor in self.custom_sensors}
        for i, sensor in enumerate(self.sensors):
            if sensor.preset not in known:
                raise ValueError(
                    f"sensors.{i}.preset: unknown sensor preset '{sensor.preset}' (known: {', '.join(sorted(known))})"
                )
        return self

    @model_validator(mode="after")
    def _motion_covers_the_frames(self) -> Scenario:
        motion_s = (self.motion.frames - 1) / self.motion.capture_hz
        if self.scan.frames is not None and self.scan.frames / self.scan.frame_rate_hz > motion_s + 1e-9:
            raise ValueError(
                f"scan.frames: {self.scan.frames} frames at {self.scan.frame_rate_hz:g} Hz need "
                f"{self.scan.frames / self.scan.frame_rate_hz:.2f} s of motion, motion.frames gives {motion_s:.2f} s"
            )
        if self.frames_per_clip() < 1:
            raise ValueError(
                f"no frames: motion.frames {self.motion.frames} at {self.motion.capture_hz} Hz give {motion_s:.2f} s "
                f"of motion, "
                f"less than one frame at scan.frame_rate_hz {self.scan.frame_rate_hz:g} (raise motion.frames or the "
                f"frame rate)"
            )
        most = format_limits(self.dataset.format).max_frames_per_clip
        if most is not None and self.frames_per_clip() > most:
            raise ValueError(
                f"scan.frames: {self.frames_per_clip()} frames per clip; the {self.dataset.format} format numbers at "
                f"most {most} (lower scan.frames or motion.frames, or use more clips)"
            )
        return self

    @model_validator(mode="after")
    def _shot_budget(self) -> Scenario:
        shots_per_s = self.shots_per_s()
        if shots_per_s > MAX_SHOTS_PER_S:
            raise ValueError(
                f"shot budget: {len(self.sensors)} sensors at scan.density {self.scan.density:g} fire "
                f"{shots_per_s:,.0f} shots/s, "
                f"more than {MAX_SHOTS_PER_S:,} (lower scan.density, the number of sensors or custom heads' "
                f"shots_per_s)"
            )
        shots_per_frame = self.shots_per_frame()
        frame_bytes = shots_per_frame * (BYTES_PER_SHOT + self.noise.subrays * BYTES_PER_RAY)
        if frame_bytes > MAX_FRAME_BYTES:
            raise ValueError(
                f"shot budget: a frame of {shots_per_frame:,.0f} shots x {self.noise.subrays} subrays needs about "
                f"{frame_bytes / 2**30:.1f} GiB, more than {MAX_FRAME_BYTES / 2**30:g} (lower noise.subrays or "
                f"scan.density, or raise scan.frame_rate_hz)"
            )
        return self


def parse_scenario(data: object, source: str = "scenario", scenario_dir: str | Path | None = None) -> Scenario:
    """Validate a parsed YAML document; raise `UserError` naming the first bad field.

    `scenario_dir`: the folder of the scenario file, which relative replay files are confined to
    (with $SIMGEN_PATTERN_DIRS); they become absolute paths in the result.
    """
    return validate(Scenario, data, source, {"scenario_dir": scenario_dir} if scenario_dir is not None else None)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    return parse_scenario(read_yaml(path, "scenario"), str(path), Path(path).parent)
