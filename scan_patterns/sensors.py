"""Sensor heads and sensors, and the registry of named presets that a scenario can extend.

A head is one Livox unit: a pattern (`risley`, `rose` or `replay`) with its parameters, a shot
rate, a circular field of view, its mounting on the sensor (yaw about z, left positive; then pitch,
up positive) and its own clock (`time_offset_s`: the head's pattern time runs that far ahead, so
identical heads do not fire in lockstep). A sensor is one or more heads.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from scan_patterns.risley import MID40, RisleyParams
from scan_patterns.rose import RoseParams

PATTERNS = ("risley", "rose", "replay")
MID40_FOV_DEG = 38.4
MID70_FOV_DEG = 70.4
MID40_SHOTS_PER_S = 100_000.0
MID100_YAWS_DEG = (-30.0, 0.0, 30.0)
MID100_TIME_OFFSETS_S = (0.0, 10.0, 20.0)  # thirds of the 30 s period of the Mid-40's prisms


@dataclass(frozen=True)
class HeadSpec:
    pattern: str  # one of PATTERNS
    params: Mapping[str, Any] = field(default_factory=dict)  # the pattern's parameters (see `model`)
    shots_per_s: float = MID40_SHOTS_PER_S  # at density x1
    fov_deg: float = MID40_FOV_DEG  # full cone angle of the circular field of view
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    time_offset_s: float = 0.0

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise ValueError(f"unknown pattern {self.pattern!r}; known: {', '.join(PATTERNS)}")
        if not (self.shots_per_s > 0 and math.isfinite(self.shots_per_s)):
            raise ValueError(f"shots_per_s must be positive, got {self.shots_per_s}")
        if not 0 < self.fov_deg < 180:
            raise ValueError(f"fov_deg must be in (0, 180), got {self.fov_deg}")
        for name in ("yaw_deg", "pitch_deg", "time_offset_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        self.model  # noqa: B018 - validates the parameters now, not at the first shot

    @property
    def model(self) -> RisleyParams | RoseParams | str:
        """The pattern's parameters: RisleyParams (MID40 with overrides), RoseParams, or the replay file."""
        params = {k: tuple(v) if isinstance(v, list) else v for k, v in self.params.items()}
        if self.pattern == "replay":
            if set(params) != {"file"}:
                raise ValueError(f"replay takes one parameter, 'file' (mid40, mid70 or a path); got {sorted(params)}")
            return str(params["file"])
        base = MID40 if self.pattern == "risley" else RoseParams()
        names = {f.name for f in dataclasses.fields(base)}
        unknown = sorted(set(params) - names)
        if unknown:
            raise ValueError(f"{self.pattern}: unknown parameter {unknown[0]!r}; known: {', '.join(sorted(names))}")
        return dataclasses.replace(base, **params)


@dataclass(frozen=True)
class SensorSpec:
    name: str
    heads: tuple[HeadSpec, ...]
    description: str = ""

    def __post_init__(self) -> None:
        if not self.heads:
            raise ValueError(f"sensor {self.name!r} has no heads")
        if len(self.heads) > 255:
            raise ValueError(f"sensor {self.name!r} has {len(self.heads)} heads; at most 255")

    @property
    def shots_per_s(self) -> float:
        """Shots per second of all heads at density x1."""
        return sum(h.shots_per_s for h in self.heads)

    @property
    def fov_span_deg(self) -> tuple[float, float]:
        """(horizontal, vertical) extent of the heads' fields of view, degrees (yaw/pitch plus cone half-angle)."""
        yaw = [(h.yaw_deg - h.fov_deg / 2, h.yaw_deg + h.fov_deg / 2) for h in self.heads]
        pitch = [(h.pitch_deg - h.fov_deg / 2, h.pitch_deg + h.fov_deg / 2) for h in self.heads]
        return (
            max(hi for _, hi in yaw) - min(lo for lo, _ in yaw),
            max(hi for _, hi in pitch) - min(lo for lo, _ in pitch),
        )


def _mid100(pattern: str) -> tuple[HeadSpec, ...]:
    return tuple(
        HeadSpec(pattern, yaw_deg=yaw, time_offset_s=offset)
        for yaw, offset in zip(MID100_YAWS_DEG, MID100_TIME_OFFSETS_S)
    )


_REGISTRY: dict[str, SensorSpec] = {}


class UnknownSensorError(KeyError, ValueError):
    """No sensor of that name is registered: a KeyError (a failed lookup) and a ValueError (bad input)."""

    def __str__(self) -> str:
        return str(self.args[0])


def register_sensor(spec: SensorSpec, replace: bool = False) -> SensorSpec:
    """Add a sensor to the registry under its name (an existing name needs `replace=True`)."""
    if spec.name in _REGISTRY and not replace:
        raise ValueError(f"sensor {spec.name!r} is already registered")
    _REGISTRY[spec.name] = spec
    return spec


def get_sensor(name: str) -> SensorSpec:
    """A registered sensor by name."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise UnknownSensorError(f"unknown sensor {name!r}; known: {', '.join(sensor_names())}") from None


def sensor_names() -> list[str]:
    return sorted(_REGISTRY)


_HEAD_KEYS = {f.name for f in dataclasses.fields(HeadSpec)}


def make_head(spec: Mapping[str, Any]) -> HeadSpec:
    """A head from a mapping of HeadSpec fields; `like: SENSOR` starts from that sensor's first head."""
    spec = dict(spec)
    base = get_sensor(spec.pop("like")).heads[0] if "like" in spec else None
    unknown = sorted(set(spec) - _HEAD_KEYS)
    if unknown:
        raise ValueError(f"head: unknown key {unknown[0]!r}; known: like, {', '.join(sorted(_HEAD_KEYS))}")
    if base is not None:
        return dataclasses.replace(base, **spec)
    if "pattern" not in spec:
        raise ValueError("head: needs 'pattern' (or 'like': a sensor name)")
    return HeadSpec(**spec)


def make_sensor(spec: Mapping[str, Any]) -> SensorSpec:
    """A sensor from a mapping {name, heads: [head mappings, see `make_head`], description} (e.g. from a scenario)."""
    unknown = sorted(set(spec) - {"name", "heads", "description"})
    if unknown:
        raise ValueError(f"sensor: unknown key {unknown[0]!r}; known: description, heads, name")
    if "name" not in spec or not spec.get("heads"):
        raise ValueError("sensor: needs 'name' and a non-empty 'heads' list")
    return SensorSpec(str(spec["name"]), tuple(make_head(h) for h in spec["heads"]), str(spec.get("description", "")))


for _spec in (
    SensorSpec("mid40-risley", (HeadSpec("risley"),), "Mid-40, Risley prisms fitted to Livox's file, never loops"),
    SensorSpec("mid40-rose", (HeadSpec("rose"),), "Mid-40 field of view, the paper's polar rose"),
    SensorSpec("mid40-replay", (HeadSpec("replay", {"file": "mid40"}),), "Livox's Mid-40 file, looped every 4 s"),
    SensorSpec(
        "mid70-replay",
        (HeadSpec("replay", {"file": "mid70"}, fov_deg=MID70_FOV_DEG),),
        "Livox's Mid-70 file (70.4 deg), looped every 4 s",
    ),
    SensorSpec("mid100-risley", _mid100("risley"), "Mid-100: three Risley Mid-40 heads yawed -30, 0, +30 deg"),
    SensorSpec("mid100-rose", _mid100("rose"), "Mid-100 layout with the paper's rose in each head"),
):
    register_sensor(_spec)
