"""The pass / fail limits of `simgen qa` and `simgen verify`: tolerances.yaml beside this module, or
a user's edited copy. Every key is required and unknown keys are refused, in one line. Reports name
the file without its folders (`Tolerances.source`): a report attached to a ticket shows no one's disk."""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

from simgen.errors import UserError
from simgen.validation import read_yaml

DEFAULT_PATH = Path(__file__).with_name("tolerances.yaml")


@dataclass(frozen=True)
class PatternTolerances:
    coverage_points: float  # percentage points
    radial_density_rel: float
    target_points_rel: float
    shot_rate_rel: float


@dataclass(frozen=True)
class DatasetTolerances:
    shots_per_frame_rel: float
    dropout_points: float  # percentage points


@dataclass(frozen=True)
class LabelTolerances:
    pitch_margin_m: float
    box_margin_m: float
    max_speed_mps: float
    min_box_size_m: float
    max_box_size_m: float


@dataclass(frozen=True)
class Tolerances:
    pattern: PatternTolerances
    dataset: DatasetTolerances
    labels: LabelTolerances
    source: str  # the file they came from: the shipped one relative to the package, a user's by name and sha256


def _section(path: Path, name: str, cls: type, data: dict) -> object:
    if name not in data:
        raise UserError(f"{path}: missing key '{name}'")
    values = data[name]
    if not isinstance(values, dict):
        raise UserError(f"{path}: '{name}' must be a mapping of tolerances")
    known = [f.name for f in dataclasses.fields(cls)]
    for key in values:
        if key not in known:
            raise UserError(f"{path}: unknown key '{name}.{key}' (known: {', '.join(known)})")
    for key in known:
        if key not in values:
            raise UserError(f"{path}: missing key '{name}.{key}'")
        value = values[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise UserError(f"{path}: '{name}.{key}' must be a number >= 0 (got {value!r})")
    return cls(**{key: float(values[key]) for key in known})


def load_tolerances(path: str | Path | None = None) -> Tolerances:
    """Tolerances from `path` (default: the shipped tolerances.yaml)."""
    path = Path(path) if path is not None else DEFAULT_PATH
    data = read_yaml(path, "tolerances")
    sections = {"pattern": PatternTolerances, "dataset": DatasetTolerances, "labels": LabelTolerances}
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected the sections {', '.join(sections)}")
    for key in data:
        if key not in sections:
            raise UserError(f"{path}: unknown key '{key}' (known: {', '.join(sections)})")
    parts = {name: _section(path, name, cls, data) for name, cls in sections.items()}
    labels = parts["labels"]
    if labels.min_box_size_m > labels.max_box_size_m:
        raise UserError(f"{path}: 'labels.min_box_size_m' is larger than 'labels.max_box_size_m'")
    return Tolerances(**parts, source=_source_name(path))


def _source_name(path: Path) -> str:
    if path.resolve() == DEFAULT_PATH.resolve():
        return f"{DEFAULT_PATH.parent.parent.name}/{DEFAULT_PATH.parent.name}/{DEFAULT_PATH.name} (shipped)"
    return f"{path.name} (sha256 {hashlib.sha256(path.read_bytes()).hexdigest()[:12]})"
