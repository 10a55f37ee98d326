"""Sensor heads and sensors, and the registry of named presets that a scenario can extend.

A head is one Livox unit: a pattern (`risley`, `rose`, `replay` or `rotors`) with its parameters, a shot
rate, its lasers (shot k fires laser (k - 1) mod lasers, Livox's `line`), a field of view (a
circular cone, or a box in azimuth and elevation), its mounting on the sensor (yaw about z, left
positive; then pitch, up positive) and its own clock (`time_offset_s`: the head's pattern time runs
that far ahead, so identical heads do not fire in lockstep). A sensor is one or more heads.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from scan_patterns.livox_tables import TABLES
from scan_patterns.metrics import FieldOfView
from scan_patterns.replay import OFFICIAL_FILES
from scan_patterns.risley import FITTED, RisleyParams
from scan_patterns.rose import RoseParams
from scan_patterns.rotors import RotorParams

PATTERNS = ("risley", "rose", "replay", "rotors")
MID40_FOV_DEG = 38.4
MID70_FOV_DEG = 70.4
MID40_SHOTS_PER_S = 100_000.0
MID100_YAWS_DEG = (-30.0, 0.0, 30.0)
MID100_TIME_OFFSETS_S = (0.0, 10.0, 20.0)  # thirds of the 30 s period of the Mid-40's prisms


@dataclass(frozen=True)
class HeadSpec:
    pattern: str  # one of PATTERNS
    params: Mapping[str, Any] = field(default_factory=dict)  # the pattern's parameters (see `model`)
    shots_per_s: float = MID40_SHOTS_PER_S  # at density x1, all lasers together
    fov_deg: float | None = MID40_FOV_DEG  # full cone angle of a circular field of view; None with fov_box_deg
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    time_offset_s: float = 0.0
    lasers: int = 1  # lasers taking turns: shot k fires laser (k - 1) mod lasers
    fov_box_deg: tuple[float, float, float, float] | None = None  # (azimuth min, max, elevation min, max), head frame

    def __post_init__(self) -> None:
        if self.pattern not in PATTERNS:
            raise ValueError(f"unknown pattern {self.pattern!r}; known: {', '.join(PATTERNS)}")
        if not (self.shots_per_s > 0 and math.isfinite(self.shots_per_s)):
            raise ValueError(f"shots_per_s must be positive, got {self.shots_per_s}")
        if (self.fov_deg is None) == (self.fov_box_deg is None):
            raise ValueError("a head has one field of view: fov_deg (a cone) or fov_box_deg (azimuth and elevation)")
        if self.fov_deg is not None and not 0 < self.fov_deg < 180:
            raise ValueError(f"fov_deg must be in (0, 180), got {self.fov_deg}")
        if self.fov_box_deg is not None:
            box = tuple(float(v) for v in self.fov_box_deg)
            if len(box) != 4 or not (-180 <= box[0] < box[1] <= 180 and -90 <= box[2] < box[3] <= 90):
                raise ValueError("fov_box_deg must be (azimuth min < max within +-180, elevation min < max within "
                                 f"+-90), got {self.fov_box_deg}")
            object.__setattr__(self, "fov_box_deg", box)
        if isinstance(self.lasers, bool) or not isinstance(self.lasers, int) or not 1 <= self.lasers <= 255:
            raise ValueError(f"lasers must be a whole number in 1..255, got {self.lasers}")
        if self.pattern == "rose" and self.fov_deg is None:
            raise ValueError("rose: draws a circular field of view, needs fov_deg")
        for name in ("yaw_deg", "pitch_deg", "time_offset_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        self.model  # noqa: B018 - validates the parameters now, not at the first shot

    @property
    def field_of_view(self) -> FieldOfView:
        """The field of view as `scan_patterns.metrics` takes it: the cone angle, or the box."""
        return self.fov_deg if self.fov_box_deg is None else self.fov_box_deg

    @property
    def extent_deg(self) -> tuple[float, float, float, float]:
        """(azimuth min, max, elevation min, max) that hold the field of view, head frame, degrees."""
        if self.fov_box_deg is not None:
            return self.fov_box_deg
        half = self.fov_deg / 2.0
        return (-half, half, -half, half)

    @property
    def half_cone_deg(self) -> float:
        """Half angle of the narrowest cone about the boresight that holds the field of view (deg)."""
        if self.fov_box_deg is None:
            return self.fov_deg / 2.0
        az_lo, az_hi, el_lo, el_hi = self.fov_box_deg
        az, el = np.radians(np.linspace(az_lo, az_hi, 361)), np.radians(np.linspace(el_lo, el_hi, 181))
        edge_az = np.concatenate([az, az, np.full(181, az[0]), np.full(181, az[-1])])
        edge_el = np.concatenate([np.full(361, el[0]), np.full(361, el[-1]), el, el])
        return float(np.degrees(np.arccos(np.clip(np.cos(edge_az) * np.cos(edge_el), -1.0, 1.0))).max())

    @property
    def model(self) -> RisleyParams | RoseParams | str:
        """The pattern's parameters: RisleyParams (`risley.FITTED[optics]`, default the Mid-40's, with
        overrides), RoseParams, RotorParams, or the replay file."""
        params = {k: tuple(v) if isinstance(v, list) else v for k, v in self.params.items()}
        if self.pattern == "replay":
            if set(params) != {"file"}:
                raise ValueError(f"replay takes one parameter, 'file' (an official name: {', '.join(OFFICIAL_FILES)}; "
                                 f"or a path); got {sorted(params)}")
            return str(params["file"])
        if self.pattern == "risley":
            optics = params.pop("optics", "mid40")
            if optics not in FITTED:
                raise ValueError(f"risley: unknown optics {optics!r}; known: {', '.join(FITTED)}")
            base, names = FITTED[optics], {"optics"}
        else:
            base, names = (RoseParams() if self.pattern == "rose" else RotorParams()), set()
        names |= {f.name for f in dataclasses.fields(base)}
        unknown = sorted(set(params) - names)
        if unknown:
            raise ValueError(f"{self.pattern}: unknown parameter {unknown[0]!r}; known: {', '.join(sorted(names))}")
        model = dataclasses.replace(base, **params)
        if self.pattern != "rose" and model.lasers != self.lasers:
            raise ValueError(f"{self.pattern}: the optics have {model.lasers} lasers, the head {self.lasers}")
        return model


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
        """(horizontal, vertical) extent of the heads' fields of view, degrees (yaw/pitch plus each head's extent)."""
        yaw = [(h.yaw_deg + h.extent_deg[0], h.yaw_deg + h.extent_deg[1]) for h in self.heads]
        pitch = [(h.pitch_deg + h.extent_deg[2], h.pitch_deg + h.extent_deg[3]) for h in self.heads]
        return (
            min(360.0, max(hi for _, hi in yaw) - min(lo for lo, _ in yaw)),
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


def find_sensor(name: str, custom: Sequence[Mapping[str, Any]] = ()) -> SensorSpec:
    """A sensor by name: the one of `custom` (`make_sensor` mappings, e.g. a scenario's custom_sensors) of that
    name, else the registered one (UnknownSensorError if neither)."""
    for spec in custom:
        if spec.get("name") == name:
            return make_sensor(spec)
    return get_sensor(name)


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


# Fields of view of the sensors with a multi-laser official table, from Livox's datasheets:
# (azimuth min, max, elevation min, max), degrees.
FOV_BOX_DEG = {
    "avia": (-35.2, 35.2, -38.6, 38.6),
    "horizon": (-40.85, 40.85, -12.55, 12.55),
    "tele": (-7.25, 7.25, -8.05, 8.05),
    "hap": (-60.0, 60.0, -12.5, 12.5),
    "mid360": (-180.0, 180.0, -7.0, 52.0),
}
# The head of each Livox sensor with an official table, replaying it (lasers and rate: `livox_tables`).
OFFICIAL_HEADS = {
    "mid40": HeadSpec("replay", {"file": "mid40"}),
    "mid70": HeadSpec("replay", {"file": "mid70"}, fov_deg=MID70_FOV_DEG),
    **{
        name: HeadSpec("replay", {"file": name}, shots_per_s=TABLES[name].shots_per_s, fov_deg=None,
                       lasers=TABLES[name].lasers, fov_box_deg=box)
        for name, box in FOV_BOX_DEG.items()
    },
}


def _fitted_head(name: str, pattern: str = "risley") -> HeadSpec:
    """The head of official table `name` drawn by the model fitted to it: `risley.FITTED[name]`, or
    the `rotors` fit of the table."""
    params = {"optics" if pattern == "risley" else "fit": name}
    return dataclasses.replace(OFFICIAL_HEADS[name], pattern=pattern, params=params)


def official_table(head: HeadSpec) -> str | None:
    """The official table of a head's kind: the one it replays, else the one whose head has its field
    of view and lasers (a fitted model, the rose); None if Livox ships none."""
    if head.pattern == "replay" and head.model in OFFICIAL_HEADS:
        return head.model
    for name, official in OFFICIAL_HEADS.items():
        if (head.fov_deg, head.fov_box_deg, head.lasers) == (official.fov_deg, official.fov_box_deg, official.lasers):
            return name
    return None


for _spec in (
    SensorSpec("mid40-risley", (HeadSpec("risley"),), "Mid-40, Risley prisms fitted to Livox's file, never loops"),
    SensorSpec("mid40-rose", (HeadSpec("rose"),), "Mid-40 field of view, the paper's polar rose"),
    SensorSpec("mid40-replay", (OFFICIAL_HEADS["mid40"],), "Livox's Mid-40 file, looped every 4 s"),
    SensorSpec("mid70-risley", (_fitted_head("mid70"),),
               "Mid-70, Risley prisms fitted to Livox's file (70.4 deg), never loops"),
    SensorSpec("mid70-replay", (OFFICIAL_HEADS["mid70"],), "Livox's Mid-70 file (70.4 deg), looped every 4 s"),
    SensorSpec("avia-risley", (_fitted_head("avia"),),
               "Avia: 6 lasers through Risley prisms fitted to Livox's table, never loops"),
    SensorSpec("avia-replay", (OFFICIAL_HEADS["avia"],),
               "Livox's Avia table: 6 lasers, 240,000 shots/s, 70.4 x 77.2 deg"),
    SensorSpec("horizon-risley", (_fitted_head("horizon"),),
               "Horizon: 6 lasers through three Risley prisms fitted to Livox's table, never loops"),
    SensorSpec("horizon-replay", (OFFICIAL_HEADS["horizon"],),
               "Livox's Horizon table: 6 lasers, 240,000 shots/s, 81.7 x 25.1 deg"),
    SensorSpec("tele15-risley", (_fitted_head("tele"),),
               "Tele-15: 6 lasers through Risley prisms fitted to Livox's table, never loops"),
    SensorSpec("tele15-replay", (OFFICIAL_HEADS["tele"],),
               "Livox's Tele-15 table: 6 lasers, 240,000 shots/s, 14.5 x 16.1 deg"),
    SensorSpec("hap-rotors", (_fitted_head("hap", "rotors"),),
               "HAP: 6 lasers, two rotors and a map fitted to Livox's table (1.7 deg rms off it), never loops"),
    SensorSpec("hap-replay", (OFFICIAL_HEADS["hap"],),
               "Livox's HAP table: 6 lasers, 452,000 shots/s, 120 x 25 deg, 2.32 s"),
    SensorSpec("mid360-rotors", (_fitted_head("mid360", "rotors"),),
               "Mid-360: 4 lasers, two rotors and a map fitted to Livox's table, never loops"),
    SensorSpec("mid360-replay", (OFFICIAL_HEADS["mid360"],),
               "Livox's Mid-360 table: 4 lasers, 200,000 shots/s, 360 x 59 deg"),
    SensorSpec("mid100-risley", _mid100("risley"), "Mid-100: three Risley Mid-40 heads yawed -30, 0, +30 deg"),
    SensorSpec("mid100-rose", _mid100("rose"), "Mid-100 layout with the paper's rose in each head"),
):
    register_sensor(_spec)
