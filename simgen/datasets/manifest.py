"""`manifest.json`: what a dataset is (format, scenario, seed, versions) and every file's rows and sha256.

Written once, after every clip, from the writers' records; no time stamp, keys sorted, so the same
input gives the same bytes. The reader trusts nothing it does not find listed here.
"""

from __future__ import annotations

import json
import platform
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path

from simgen.datasets.records import FileRecord
from simgen.datasets.schema import BOX_CONVENTION, PITCH_FRAME, SCHEMA_VERSION
from simgen.errors import UserError

MANIFEST_NAME = "manifest.json"
FORMATS = ("parquet", "kitti", "kitti_tracking", "openpcdet", "mcap")
#: Packages whose versions shape the data (the engine, ray casting, meshes, arrays, files).
DATA_DEPENDENCIES = ("gfootball", "numpy", "open3d-cpu", "pyarrow", "pydantic", "scipy", "trimesh")


@dataclass(frozen=True)
class ClipEntry:
    """A clip as the manifest lists it."""

    clip: str
    clip_index: int
    frames: int
    points: int
    boxes: int
    split: str  # train or val


@dataclass(frozen=True)
class Manifest:
    format: str
    schema_version: int
    simgen_version: str
    dependencies: dict[str, str]
    scenario: dict
    seed: int
    sensors: tuple[dict, ...]
    clips: tuple[ClipEntry, ...]
    files: tuple[FileRecord, ...]

    def to_dict(self) -> dict:
        return {
            **asdict(self),
            "conventions": {"pitch_frame": PITCH_FRAME, "boxes": BOX_CONVENTION},
            "totals": {key: sum(getattr(c, key) for c in self.clips) for key in ("frames", "points", "boxes")},
        }

    @classmethod
    def from_dict(cls, data: dict) -> Manifest:
        return cls(
            format=data["format"],
            schema_version=data["schema_version"],
            simgen_version=data["simgen_version"],
            dependencies=data["dependencies"],
            scenario=data["scenario"],
            seed=data["seed"],
            sensors=tuple(data["sensors"]),
            clips=tuple(ClipEntry(**c) for c in data["clips"]),
            files=tuple(FileRecord(**f) for f in data["files"]),
        )


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


def read_manifest(root: Path) -> Manifest:
    """The dataset's manifest; a missing, malformed or foreign one is a one-line `UserError`."""
    path = root / MANIFEST_NAME
    if not root.is_dir():
        raise UserError(f"{root}: no such dataset directory")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"{root}: no {MANIFEST_NAME}, not a simgen dataset") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise UserError(f"{path}: not a readable manifest ({error.__class__.__name__}: {error})") from None
    if not isinstance(data, dict) or data.get("schema_version") != SCHEMA_VERSION:
        version = data.get("schema_version") if isinstance(data, dict) else None
        raise UserError(f"{path}: dataset schema version {version}, this simgen reads {SCHEMA_VERSION}")
    if data.get("format") not in FORMATS:
        raise UserError(f"{path}: unknown format {data.get('format')!r} (simgen writes {', '.join(FORMATS)})")
    try:
        return Manifest.from_dict(data)
    except (KeyError, TypeError) as error:
        raise UserError(f"{path}: malformed manifest ({error.__class__.__name__}: {error})") from None
