"""The numbers a coverage report states: shares of an area's cells, points by distance, shares of player-frames.

Areas: `pitch`, every cell of the grid; `paper`, the cells inside the paper's detection range, [-40, 40] m
in x and y of the pitch frame (the detector configs' `point_range_m`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

AREAS = ("pitch", "paper")
PAPER_HALF_RANGE_M = 40.0
DISTANCE_BIN_M = 10.0
PLAYER_FRAME_THRESHOLDS = (1, 5, 20)  # points per frame the report counts player-frames at


def in_area(centres_m: NDArray, area: str) -> NDArray[np.bool_]:
    """(C,) which cells (centres (C, 2), metres) lie in the area."""
    if area == "pitch":
        return np.ones(len(centres_m), bool)
    return (np.abs(centres_m) <= PAPER_HALF_RANGE_M).all(axis=1)


def share_at_least(values: NDArray, threshold: float) -> float:
    """Share (0..1) of values at least `threshold`; NaN for none."""
    return float(np.mean(values >= threshold)) if len(values) else float("nan")


@dataclass(frozen=True)
class DistanceBins:
    """Points per player per frame by horizontal distance to the rig's nearest sensor, in DISTANCE_BIN_M bins."""

    lower_m: NDArray[np.float64]  # (B,) each bin's lower edge
    count: NDArray[np.int64]  # (B,) samples (player-frames) in the bin
    median: NDArray[np.float64]  # (B,) median points (NaN where empty)
    none: NDArray[np.float64]  # (B,) share with no point (NaN where empty)


def by_distance(distance_m: NDArray, points: NDArray, max_m: float | None = None) -> DistanceBins:
    """Bin samples (N,) of distance (m) and points; bins from 0 to the farthest sample (or `max_m`)."""
    top = max_m if max_m is not None else (float(distance_m.max()) if len(distance_m) else DISTANCE_BIN_M)
    bins = max(1, int(np.ceil(top / DISTANCE_BIN_M)))
    index = np.minimum((distance_m // DISTANCE_BIN_M).astype(np.int64), bins - 1)
    median, none, count = np.full(bins, np.nan), np.full(bins, np.nan), np.zeros(bins, np.int64)
    for b in range(bins):
        values = points[index == b]
        count[b] = len(values)
        if len(values):
            median[b], none[b] = np.median(values), np.mean(values == 0)
    return DistanceBins(DISTANCE_BIN_M * np.arange(bins), count, median, none)


def nearest_distance(centres_m: NDArray, sensors_xy_m: NDArray) -> NDArray[np.float64]:
    """(C,) horizontal distance (m) from each point (C, 2) to the nearest sensor (S, 2)."""
    offset = centres_m[:, None, :] - sensors_xy_m[None]
    return np.hypot(offset[..., 0], offset[..., 1]).min(axis=1)


def cell_means(position_m: NDArray, values: NDArray, x_edges: NDArray, y_edges: NDArray) -> NDArray[np.float64]:
    """(X, Y) mean of values (N,) of the samples at positions (N, 2) in each cell of the edges; NaN where none."""
    total, _, _ = np.histogram2d(position_m[:, 0], position_m[:, 1], [x_edges, y_edges], weights=values)
    count, _, _ = np.histogram2d(position_m[:, 0], position_m[:, 1], [x_edges, y_edges])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)
