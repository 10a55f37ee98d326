"""Where to mount K sensors of one model: a greedy pick among candidate mounting positions on the coverage
objective (the share of an area's cells where a standing player gets at least N points per frame).

A candidate file (YAML, validated like a scenario):

    preset: mid100-rose            # the one sensor model
    masts:                         # each mast: where it stands, and the heights, tilts and yaws to try there
      - {name: west_goal, x: -58.0, y: 0.0, z: [6.0, 8.0], pitch: [-6.0, -10.0], yaw: 0.0}

`z`, `pitch`, `yaw` (and `roll`) take a number or a list; a mast's candidates are every combination. Standing
players alone add up over sensors, so each candidate's grid is rendered once, alone, and the greedy search
sums them: it adds, K times, the candidate that raises the objective most (ties: the one that raises the
points short of N least, `soft_coverage`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

import scan_patterns
from simgen.coverage.grid import grid_coverage
from simgen.errors import UserError
from simgen.scenario import Scenario, SensorPose
from simgen.validation import Strict, read_yaml, validate

MAX_CANDIDATES = 256  # each is one grid rendered: about 4 s at 1 m for a Mid-100 on one core


def _values(low: float, high: float):
    number = Annotated[float, Field(ge=low, le=high)]
    return number | list[number]


class MastConfig(Strict):
    """One mast and the mountings to try on it (a number or a list each; every combination is a candidate)."""

    name: str = Field(..., pattern=r"^[A-Za-z0-9_.-]+$", max_length=48)
    x: float = Field(..., ge=-200, le=200)
    y: float = Field(..., ge=-200, le=200)
    z: _values(0.0, 100.0) = Field(..., description="Heights above the ground, metres.")
    roll: _values(-180.0, 180.0) = 0.0
    pitch: _values(-90.0, 90.0) = Field(..., description="Tilts, degrees (negative: looking down).")
    yaw: _values(-360.0, 360.0) = Field(..., description="Headings, degrees (0: along +x, 90: along +y).")

    @field_validator("z", "roll", "pitch", "yaw")
    @classmethod
    def _short_lists(cls, value):
        if isinstance(value, list) and not 1 <= len(value) <= MAX_CANDIDATES:
            raise ValueError(f"a list of 1 to {MAX_CANDIDATES} values")
        return value

    def count(self) -> int:
        return math.prod(len(v) if isinstance(v, list) else 1 for v in (self.z, self.roll, self.pitch, self.yaw))


class CandidatesConfig(Strict):
    """A candidate file: one sensor preset and the masts."""

    preset: str = Field(..., max_length=64, description="Sensor preset of every candidate (scan_patterns).")
    masts: list[MastConfig] = Field(..., min_length=1, max_length=MAX_CANDIDATES)

    @field_validator("preset")
    @classmethod
    def _known(cls, preset: str) -> str:
        if preset not in scan_patterns.sensor_names():
            raise ValueError(f"unknown sensor preset '{preset}' (known: {', '.join(scan_patterns.sensor_names())})")
        return preset


@dataclass(frozen=True)
class Candidate:
    name: str  # mast, height, tilt and heading, e.g. west_goal_z8_p-10_y0
    pose: SensorPose


def _listed(value) -> list[float]:
    return value if isinstance(value, list) else [value]


def load_candidates(path: str | Path) -> tuple[str, list[Candidate]]:
    """The preset and the candidates of a candidate file; more than MAX_CANDIDATES is a `UserError`, counted
    before any is made."""
    config = validate(CandidatesConfig, read_yaml(path, "candidates"), str(path))
    total = sum(mast.count() for mast in config.masts)
    if total > MAX_CANDIDATES:
        raise UserError(f"{path}: {total:,} candidates, more than {MAX_CANDIDATES} (each is a grid to render)")
    candidates = []
    for mast in config.masts:
        for z, roll, pitch, yaw in itertools.product(*map(_listed, (mast.z, mast.roll, mast.pitch, mast.yaw))):
            name = f"{mast.name}_z{z:g}_p{pitch:g}_y{yaw:g}" + (f"_r{roll:g}" if roll else "")
            candidates.append(Candidate(name, SensorPose(x=mast.x, y=mast.y, z=z, roll=roll, pitch=pitch, yaw=yaw)))
    names = [c.name for c in candidates]
    for name in names:
        if names.count(name) > 1:
            raise UserError(f"{path}: candidate '{name}' is listed twice")
    return config.preset, candidates


def with_sensors(scenario: Scenario, name: str, preset: str, candidates: list[Candidate]) -> Scenario:
    """The scenario, renamed, with the candidates as its sensors."""
    data = scenario.model_dump()
    data["name"] = name
    data["description"] = f"{scenario.name} with {len(candidates)} {preset} picked by simgen coverage --candidates"
    data["sensors"] = [{"name": c.name, "preset": preset, "pose": c.pose.model_dump()} for c in candidates]
    return Scenario.model_validate(data)


def soft_coverage(points: NDArray, min_points: float) -> NDArray[np.float64]:
    """Per cell, points per frame as a share of `min_points`, at most 1."""
    return np.minimum(points / max(min_points, 1e-9), 1.0)


def greedy_pick(means: NDArray, cells: NDArray, min_points: float, k: int) -> list[int]:
    """Indices of k candidates (rows of means (M, C): each one's points per frame per cell) that, added one at a
    time, raise most the share of `cells` (C,) where the sum reaches `min_points`."""
    total = np.zeros(means.shape[1])
    chosen: list[int] = []
    for _ in range(k):
        best, best_key = -1, None
        for i in range(len(means)):
            if i in chosen:
                continue
            trial = (total + means[i])[cells]
            key = (np.mean(trial >= min_points), np.mean(soft_coverage(trial, min_points)))
            if best_key is None or key > best_key:
                best, best_key = i, key
        chosen.append(best)
        total += means[best]
    return chosen


def pick_rig(
    scenario: Scenario,
    preset: str,
    candidates: list[Candidate],
    k: int,
    step_m: float,
    headings_deg: NDArray,
    cells: NDArray,
    min_points: float,
    progress: Callable[[int, int], None] | None = None,
) -> Scenario:
    """Render each candidate alone on the grid (with the scenario's scan, noise and scene), pick k greedily and
    return the scenario with them as its sensors; `progress(done, total)` is told of each candidate."""
    means = []
    for i, candidate in enumerate(candidates):
        alone = with_sensors(scenario, scenario.name, preset, [candidate])
        means.append(grid_coverage(alone, step_m, headings_deg).rig_mean.astype(np.float32))
        if progress is not None:
            progress(i + 1, len(candidates))
    chosen = greedy_pick(np.stack(means), cells, min_points, k)
    return with_sensors(scenario, f"{scenario.name}_pick{k}", preset, [candidates[i] for i in chosen])
