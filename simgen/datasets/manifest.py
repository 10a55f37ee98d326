"""`manifest.json`: what a dataset is (format, scenario, seed, versions) and every file's rows and sha256.

Written once, after every clip, from the writers' records; no time stamp, keys sorted, so the same
input gives the same bytes. The reader trusts nothing it does not find listed here, and reads the
file through a strict pydantic model (`ManifestFile`): a field of the wrong type or range, a path
that leaves the dataset, a file or clip listed twice or totals that do not add up are one line
naming the field.
"""

from __future__ import annotations

import json
import platform
import re
from dataclasses import asdict, dataclass, replace
from importlib import metadata
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, ValidationError, model_validator

from simgen.datasets.formats import FORMATS
from simgen.datasets.limits import check_boxes, check_points, max_points_per_frame
from simgen.datasets.records import FileRecord
from simgen.datasets.schema import BOX_CONVENTION, PITCH_FRAME, SCHEMA_VERSION
from simgen.errors import UserError
from simgen.scan.sensor import Sensor
from simgen.validation import Strict, one_line, read_limited

MANIFEST_NAME = "manifest.json"
#: Packages whose versions shape the data (the engine, ray casting, meshes, arrays, files).
DATA_DEPENDENCIES = ("gfootball", "numpy", "open3d-cpu", "pyarrow", "pydantic", "scipy", "trimesh")
MAX_MANIFEST_BYTES = 1 << 30  # a million files at ~200 bytes each fit ~5 times over
#: Names beside the listed files that are not data: the manifest itself, the card, the run state.
RESERVED_NAMES = (MANIFEST_NAME, "README.md", ".simgen")


@dataclass(frozen=True)
class ClipEntry:
    """A clip as the manifest lists it."""

    clip: str
    clip_index: int
    frames: int
    points: int
    boxes: int
    split: str  # train or val
    start_s: float  # game time of frame 0's sweep start: frame k's is start_s + k / frame_rate_hz


@dataclass(frozen=True)
class Manifest:
    format: str
    schema_version: int
    simgen_version: str
    dependencies: dict[str, str]
    scenario: dict
    seed: int
    sensors: tuple[Sensor, ...]
    clips: tuple[ClipEntry, ...]
    files: tuple[FileRecord, ...]
    labels: dict[str, float | None]  # LabelStatistics.summary() over every clip

    def to_dict(self) -> dict:
        return {
            **asdict(replace(self, sensors=())),
            "sensors": [sensor.record() for sensor in self.sensors],
            "conventions": {"pitch_frame": PITCH_FRAME, "boxes": BOX_CONVENTION},
            "totals": {key: sum(getattr(c, key) for c in self.clips) for key in ("frames", "points", "boxes")},
        }

    @classmethod
    def from_dict(cls, data: dict) -> Manifest:
        """From a manifest.json document; `ValidationError` naming the first bad field, ValueError a sensor whose
        preset its scenario does not resolve."""
        valid = ManifestFile.model_validate(data, strict=True)  # no coercion: JSON's types as written
        return cls(
            format=valid.format,
            schema_version=valid.schema_version,
            simgen_version=valid.simgen_version,
            dependencies=dict(valid.dependencies),
            scenario=data["scenario"],
            seed=valid.seed,
            sensors=tuple(Sensor.from_record(s.model_dump(), data["scenario"]) for s in valid.sensors),
            clips=tuple(ClipEntry(**c.model_dump()) for c in valid.clips),
            files=tuple(FileRecord(**f.model_dump()) for f in valid.files),
            labels=dict(valid.labels),
        )


def _inside_the_dataset(path: str) -> str:
    """A listed path: relative, POSIX, below the dataset root, not one of `RESERVED_NAMES`."""
    parts = path.split("/")
    if path.startswith("/") or "\\" in path or any(part in ("", ".", "..") for part in parts):
        raise ValueError(f"{path[:80]!r} is not a relative path inside the dataset")
    if re.search(r"[\x00-\x1f\x7f]", path) or parts[0] in RESERVED_NAMES:
        raise ValueError(f"{path[:80]!r} is not a data file's name")
    return path


Count = Annotated[int, Field(ge=0, lt=2**63)]
Number = Annotated[float, Field(ge=-1e6, le=1e6)]


class FileEntry(Strict):
    path: Annotated[str, Field(min_length=1, max_length=1024), AfterValidator(_inside_the_dataset)]
    rows: Count
    bytes: Count
    sha256: str = Field(pattern=r"^[0-9a-f]{64}$")


class ClipItem(Strict):
    clip: str = Field(pattern=r"^[A-Za-z][A-Za-z0-9_.-]*$", max_length=128)
    clip_index: int = Field(ge=0, lt=100_000)
    frames: int = Field(ge=1, le=1_000_000)
    points: Count
    boxes: Count
    split: Literal["train", "val"]
    start_s: Number


class SensorItem(Strict):
    """`simgen.scan.sensor.Sensor.record()` as the manifest lists it (validated as it is read)."""

    sensor_id: int = Field(ge=0, lt=256)
    name: str = Field(max_length=128)
    preset: str = Field(max_length=128)
    pose: list[Number] = Field(min_length=6, max_length=6)
    heads: int = Field(ge=1, le=255)
    shots_per_s: float = Field(gt=0, le=1e9)
    frame_rate_hz: float = Field(gt=0, le=1000)
    sweeps_per_frame: int = Field(ge=1, le=255)
    density: float = Field(gt=0, le=1000)


class Totals(Strict):
    frames: Count
    points: Count
    boxes: Count


class ManifestFile(Strict):
    """manifest.json, field by field."""

    format: Literal[FORMATS]
    schema_version: Literal[SCHEMA_VERSION]
    simgen_version: str = Field(max_length=64)
    dependencies: dict[str, str]
    scenario: dict[str, Any]
    seed: int = Field(ge=0, lt=2**63)
    sensors: list[SensorItem] = Field(min_length=1, max_length=255)
    clips: list[ClipItem] = Field(min_length=1)
    files: list[FileEntry] = Field(min_length=1)
    conventions: dict[str, str]
    totals: Totals
    labels: dict[
        Annotated[str, Field(max_length=64)], Annotated[float, Field(ge=0, le=1e15)] | None
    ] = Field(max_length=64)  # label statistics

    @model_validator(mode="after")
    def _consistent(self) -> ManifestFile:
        for name, values in (
            ("files: path", [f.path for f in self.files]),
            ("clips: clip", [c.clip for c in self.clips]),
            ("clips: clip_index", [c.clip_index for c in self.clips]),
            ("sensors: sensor_id", [s.sensor_id for s in self.sensors]),
        ):
            if len(set(values)) != len(values):
                raise ValueError(f"{name} {_first_repeat(values)!r} is listed twice")
        for key in ("frames", "points", "boxes"):
            total = sum(getattr(c, key) for c in self.clips)
            if getattr(self.totals, key) != total:
                raise ValueError(f"totals.{key} is {getattr(self.totals, key)}, the clips add up to {total}")
        return self


def _first_repeat(values: list) -> object:
    seen = set()
    for value in values:
        if value in seen:
            return value
        seen.add(value)
    return None


def dependency_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for name in DATA_DEPENDENCIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def manifest_bytes(manifest: Manifest) -> bytes:
    return (json.dumps(manifest.to_dict(), indent=1, sort_keys=True) + "\n").encode()


def read_manifest(root: Path, name: str = MANIFEST_NAME) -> Manifest:
    """The dataset's manifest (`root / name`); a missing, malformed or foreign one is a one-line `UserError`."""
    path = root / name
    if not root.is_dir():
        raise UserError(f"{root}: no such dataset directory")
    if not path.exists() and not path.is_symlink():
        raise UserError(f"{root}: no {name}, not a simgen dataset")
    raw = read_limited(path, "manifest", MAX_MANIFEST_BYTES)
    try:
        data = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as error:
        message = (
            " ".join(str(error).splitlines())[:120] if not isinstance(error, RecursionError) else "nested too deeply"
        )
        raise UserError(f"{path}: not a readable manifest ({error.__class__.__name__}: {message})") from None
    if not isinstance(data, dict) or data.get("schema_version") != SCHEMA_VERSION:
        version = data.get("schema_version") if isinstance(data, dict) else None
        raise UserError(f"{path}: dataset schema version {version}, this simgen reads {SCHEMA_VERSION}")
    if data.get("format") not in FORMATS:
        raise UserError(f"{path}: unknown format {data.get('format')!r} (simgen writes {', '.join(FORMATS)})")
    try:
        manifest = Manifest.from_dict(data)
    except ValidationError as error:
        extra = f" (and {error.error_count() - 1} more)" if error.error_count() > 1 else ""
        raise UserError(f"{path}: malformed manifest: {one_line(error)}{extra}") from None
    except ValueError as error:
        raise UserError(f"{path}: malformed manifest: {error}") from None
    most = max_points_per_frame(manifest.sensors)
    for entry in manifest.clips:
        check_points(path, f"clip {entry.clip}", entry.points, entry.frames, most)
        check_boxes(path, f"clip {entry.clip}", entry.boxes, entry.frames)
    return manifest
