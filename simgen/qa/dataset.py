"""What a dataset's frames hold: points, shots, dropout and misses per frame, intensities, and the
points each humanoid got against its range and off-axis angle from the sensor that saw it.

Shot counts come from the Parquet `frames` table (other formats keep none). Points per humanoid
are counted per sensor by the points' instance ids (Parquet), or else as the points inside the
box grown by `labels.box_margin_m`, credited to the nearest sensor. The off-axis angle is the
angle from the boresight of the sensor's nearest head.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.reader import Dataset
from simgen.qa.checks import Check
from simgen.qa.label_checks import in_box
from simgen.qa.tolerances import DatasetTolerances, LabelTolerances
from simgen.scan.sensor import Sensor

BINOMIAL_SIGMAS = 4.0  # the dropout check allows this many binomial standard deviations besides its tolerance
GROUND_CLEARANCE_M = 0.05  # points lower than this inside a box are ground, not the humanoid


@dataclass(frozen=True)
class FrameCounts:
    """Per frame, all clips: points always; shots, dropped and missed from the Parquet frames table."""

    points: NDArray[np.int64]
    shots: NDArray[np.int64] | None
    dropped: NDArray[np.int64] | None
    missed: NDArray[np.int64] | None


@dataclass(frozen=True)
class HumanoidSamples:
    """One row per (sampled frame, humanoid, sensor)."""

    range_m: NDArray[np.float64]  # sensor to box centre
    off_axis_deg: NDArray[np.float64]  # from the nearest head's boresight
    in_fov: NDArray[np.bool_]  # box centre within a head's field of view
    points: NDArray[np.int64]


@dataclass(frozen=True)
class DatasetQA:
    sensors: tuple[Sensor, ...]
    counts: FrameCounts
    humanoids: HumanoidSamples
    intensity: NDArray[np.int64]  # (256,) points per intensity value, sampled frames
    frames_sampled: int
    frames_total: int
    checks: tuple[Check, ...]


def frame_sample(dataset: Dataset, max_frames: int) -> list[tuple[str, int]]:
    """At most `max_frames` (clip, frame index), evenly spread over the dataset."""
    every = [(clip, i) for clip in dataset.clips for i in range(dataset.num_frames(clip))]
    if len(every) <= max_frames:
        return every
    return [every[i] for i in np.linspace(0, len(every) - 1, max_frames).round().astype(int)]


def frame_counts(dataset: Dataset, sampled_points: list[int]) -> FrameCounts:
    """Counts of every frame where the format keeps them (Parquet's frames tables); else the sampled frames' points."""
    column = dataset.plugin.frame_counts(dataset.files, dataset.clips)
    if column is None:
        return FrameCounts(np.array(sampled_points, np.int64), None, None, None)
    return FrameCounts(column["num_points"], column["shots"], column["dropped"], column["missed"])


def _humanoid_points(frame, sensors: tuple[Sensor, ...], margin_m: float) -> NDArray[np.int64]:
    """(H, sensors) points per humanoid and sensor (see the module docstring)."""
    counts = np.zeros((len(frame.boxes), len(sensors)), np.int64)
    if frame.instance_id is not None:
        for s in range(len(sensors)):
            mine = frame.instance_id[frame.sensor == s]
            counts[:, s] = [(mine == t).sum() for t in frame.track_id]
        return counts
    above = frame.points_m[frame.points_m[:, 2] >= GROUND_CLEARANCE_M]
    for i, box in enumerate(np.asarray(frame.boxes, np.float64)):
        nearest = int(np.argmin([np.linalg.norm(box[:3] - s.origin_m) for s in sensors]))
        counts[i, nearest] = in_box(above, box, margin_m).sum()
    return counts


def humanoid_samples(dataset: Dataset, sample, sensors, margin_m: float) -> tuple[HumanoidSamples, NDArray, list[int]]:
    """Per (frame, humanoid, sensor) samples, the intensity histogram and the points of each sampled frame."""
    rows: list[tuple[NDArray, ...]] = []
    intensity = np.zeros(256, np.int64)
    points = []
    for clip, index in sample:
        frame = dataset.frame(clip, index)
        points.append(len(frame.points_m))
        intensity += np.bincount(frame.intensity, minlength=256)
        counts = _humanoid_points(frame, sensors, margin_m)
        rows += [(*sensor.view_angles(frame.boxes[:, :3]), counts[:, s]) for s, sensor in enumerate(sensors)]
    columns = [np.concatenate(c) for c in zip(*rows)] if rows else [np.zeros(0)] * 4
    samples = HumanoidSamples(columns[0], columns[1], columns[2].astype(bool), columns[3].astype(np.int64))
    return samples, intensity, points


def dataset_checks(dataset: Dataset, counts: FrameCounts, tol: DatasetTolerances) -> list[Check]:
    """Shots per frame against the sensors' rate, dropout against the scenario's, no empty frame."""
    empty = int((counts.points == 0).sum())
    checks = [Check("dataset", "frames with no point", f"{empty} of {len(counts.points)}", "0", empty == 0)]
    if counts.shots is None:
        reason = f"{dataset.format} keeps no shot counts"
        return checks + [Check("dataset", name, reason, "", None) for name in ("shots per frame", "dropout")]
    sensors = dataset.manifest.sensors
    expected = sum(s.shots_per_s for s in sensors) / sensors[0].frame_rate_hz
    worst = float(np.max(np.abs(counts.shots - expected)) / expected)
    checks.append(Check("dataset", "shots per frame", f"{worst:z.3%} from {expected:,.0f} at worst",
                        f"<= {tol.shots_per_frame_rel:.1%}", worst <= tol.shots_per_frame_rel))
    noise = dataset.manifest.scenario.get("noise", {})
    want = float(noise.get("dropout", 0.0)) if noise.get("enabled", True) else 0.0
    returns = int((counts.points + counts.dropped).sum())
    share = counts.dropped.sum() / max(returns, 1)
    allowed = tol.dropout_points / 100 + BINOMIAL_SIGMAS * np.sqrt(want * (1 - want) / max(returns, 1))
    checks.append(Check("dataset", "dropout", f"{share:.3%} of {returns:,} returns, scenario {want:.3%}",
                        f"<= {tol.dropout_points:g} points (+{BINOMIAL_SIGMAS:g} sigma)", abs(share - want) <= allowed))
    return checks


def dataset_qa(dataset: Dataset, dtol: DatasetTolerances, ltol: LabelTolerances, max_frames: int) -> DatasetQA:
    """Counts of every frame, humanoid samples of at most `max_frames` frames, and the dataset checks."""
    sensors = dataset.manifest.sensors
    sample = frame_sample(dataset, max_frames)
    humanoids, intensity, points = humanoid_samples(dataset, sample, sensors, ltol.box_margin_m)
    counts = frame_counts(dataset, points)
    return DatasetQA(sensors, counts, humanoids, intensity, len(sample), len(dataset),
                     tuple(dataset_checks(dataset, counts, dtol)))
