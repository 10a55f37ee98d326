"""Label statistics: how much a humanoid's box changes from one frame to the next, and its points.

Kept as histograms so that frames, shards and clips add up exactly: per track and pair of consecutive
frames, the change of length, width and height (`SIZE_BIN_M` bins) and of heading (`HEADING_BIN_DEG`
bins), never across a placement (`FrameLabels.discontinuity`); per box, its points (a bin per count up
to `MAX_POINTS`, the last holding more). Quantiles are read at bin centres, to half a bin. A shard
written in place (KITTI, OpenPCDet) counts its seam's pair from the previous frame's boxes, so a clip's
shards add up to the whole clip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

SIZE_BIN_M = 0.005
SIZE_BINS = 600  # changes up to 3 m, the largest box
HEADING_BIN_DEG = 0.5
HEADING_BINS = 360  # 0-180 degrees
MAX_POINTS = 2000
SIZE_NAMES = ("length", "width", "height")


@dataclass
class LabelStatistics:
    size_change: NDArray[np.int64]  # (3, SIZE_BINS) counts of |change| of length, width, height per frame
    heading_change: NDArray[np.int64]  # (HEADING_BINS,) counts of |change| of heading per frame
    points: NDArray[np.int64]  # (MAX_POINTS + 1,) boxes by their point count
    _last: dict | None = None  # track id -> (size (3,), yaw) in the previous frame added

    @classmethod
    def empty(cls) -> LabelStatistics:
        return cls(
            np.zeros((3, SIZE_BINS), np.int64), np.zeros(HEADING_BINS, np.int64), np.zeros(MAX_POINTS + 1, np.int64)
        )

    def add(self, track_id: NDArray, boxes: NDArray, discontinuity: NDArray | None, num_points: NDArray | None) -> None:
        """One frame's boxes (H, 7) with their track ids, placement flags and point counts (None: not kept),
        after the frame before it (or first)."""
        boxes = np.asarray(boxes, np.float64).reshape(-1, 7)
        if num_points is not None:
            self.points += np.bincount(
                np.minimum(np.asarray(num_points, np.int64), MAX_POINTS), minlength=MAX_POINTS + 1
            )
        placed = np.zeros(len(boxes), bool) if discontinuity is None else np.asarray(discontinuity, bool)
        if self._last is not None:
            pairs = [(i, self._last[int(t)]) for i, t in enumerate(track_id) if int(t) in self._last and not placed[i]]
            if pairs:
                rows = np.array([i for i, _ in pairs])
                size = np.abs(boxes[rows, 3:6] - np.array([s for _, (s, _) in pairs]))
                turn = np.abs(np.angle(np.exp(1j * (boxes[rows, 6] - np.array([y for _, (_, y) in pairs])))))
                for k in range(3):
                    self.size_change[k] += _counts(size[:, k] / SIZE_BIN_M, SIZE_BINS)
                self.heading_change += _counts(np.degrees(turn) / HEADING_BIN_DEG, HEADING_BINS)
        self._last = {int(t): (boxes[i, 3:6].copy(), boxes[i, 6]) for i, t in enumerate(track_id)}

    def merged(self, other: LabelStatistics) -> LabelStatistics:
        return LabelStatistics(self.size_change + other.size_change, self.heading_change + other.heading_change,
                               self.points + other.points)

    def to_dict(self) -> dict:
        return {
            "size_change": self.size_change.tolist(),
            "heading_change": self.heading_change.tolist(),
            "points": self.points.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> LabelStatistics:
        return cls(*(np.asarray(data[name], np.int64) for name in ("size_change", "heading_change", "points")))

    def summary(self) -> dict[str, float | None]:
        """Medians and upper percentiles (sizes in metres, heading in degrees), boxes, the share without points;
        None where there is nothing to count."""
        out: dict[str, float | None] = {
            "boxes": float(self.points.sum()),
            "share_without_points": _share(self.points[0], self.points.sum()),
        }
        out["points_median"], out["points_p90"] = (_quantile(self.points, q, 1.0, 0.0) for q in (0.5, 0.9))
        for k, name in enumerate(SIZE_NAMES):
            for q, label in ((0.5, "median"), (0.9, "p90")):
                out[f"{name}_change_{label}_m"] = _quantile(self.size_change[k], q, SIZE_BIN_M)
        for q, label in ((0.5, "median"), (0.9, "p90"), (0.99, "p99")):
            out[f"heading_change_{label}_deg"] = _quantile(self.heading_change, q, HEADING_BIN_DEG)
        out["frame_pairs"] = float(self.heading_change.sum())
        return out


def _counts(scaled: NDArray[np.float64], bins: int) -> NDArray[np.int64]:
    return np.bincount(np.minimum(scaled.astype(np.int64), bins - 1), minlength=bins)


def _quantile(counts: NDArray[np.int64], q: float, width: float, offset: float = 0.5) -> float | None:
    """The q-quantile of a histogram of `width` bins, at the bin's centre (`offset` 0: its lower edge)."""
    total = counts.sum()
    if total == 0:
        return None
    return round(float((np.searchsorted(np.cumsum(counts), q * total) + offset) * width), 6)


def _share(part: float, total: float) -> float | None:
    return round(float(part) / float(total), 6) if total else None


def summary_rows(summary: dict[str, float | None]) -> list[tuple[str, str, str, str]]:
    """(quantity, median, 90th percentile, 99th percentile) rows of a `LabelStatistics.summary()`, as text."""

    def cell(key: str, digits: int) -> str:
        value = summary.get(key)
        return "–" if value is None else f"{value:.{digits}f}"

    rows = [(f"{name} change per frame, m", cell(f"{name}_change_median_m", 3), cell(f"{name}_change_p90_m", 3), "–")
            for name in SIZE_NAMES]
    rows.append(
        (
            "heading change per frame, degrees",
            cell("heading_change_median_deg", 1),
            cell("heading_change_p90_deg", 1),
            cell("heading_change_p99_deg", 1),
        )
    )
    share = summary.get("share_without_points")
    rows.append(("points per box", cell("points_median", 0), cell("points_p90", 0), "–"))
    rows.append(("boxes without a point", "–" if share is None else f"{share:.1%}", "–", "–"))
    return rows
