"""Label statistics: per-frame changes of box size and heading (none across a placement), points per box,
merged over shards to the same numbers as one pass, and shown in the dataset card and the QA report."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.labels.statistics import HEADING_BIN_DEG, SIZE_BIN_M, LabelStatistics
from tests.support.datasets import make_clip, write_dataset

BOX = [0.0, 0.0, 0.9, 0.6, 0.5, 1.8, 0.0]


def _boxes(length: float, yaw_deg: float) -> np.ndarray:
    return np.array([[*BOX[:3], length, 0.5, 1.8, np.radians(yaw_deg)]])


def test_changes_per_frame_skip_placements_and_merge_exactly():
    """One track whose length alternates 0.60/0.80 m and heading turns 10 degrees a frame; frame 3 placed (no
    pair with frame 2). Medians at the bin centres; the last frame's box has no point."""
    frames = [(_boxes(0.6 + 0.2 * (k % 2), 10.0 * k), k == 3, 5 - k) for k in range(6)]
    whole = LabelStatistics.empty()
    for boxes, placed, points in frames:
        whole.add(np.array([7]), boxes, np.array([placed]), np.array([points]))
    summary = whole.summary()
    assert summary["frame_pairs"] == 4 and summary["boxes"] == 6
    assert summary["length_change_median_m"] == pytest.approx(0.2 + SIZE_BIN_M / 2, abs=1e-9)
    assert summary["width_change_median_m"] == pytest.approx(SIZE_BIN_M / 2)
    assert summary["heading_change_median_deg"] == pytest.approx(10 + HEADING_BIN_DEG / 2)
    assert summary["share_without_points"] == pytest.approx(1 / 6, abs=1e-6) and summary["points_median"] == 2
    first, second = LabelStatistics.empty(), LabelStatistics.empty()
    for part, chunk in ((first, frames[:3]), (second, frames[3:])):  # shards that meet at a placement lose nothing
        for boxes, placed, points in chunk:
            part.add(np.array([7]), boxes, np.array([placed]), np.array([points]))
    merged = first.merged(LabelStatistics.from_dict(second.to_dict()))
    assert merged.summary() == summary


def test_the_card_and_the_qa_report_show_them(tmp_path):
    from simgen.cli import main

    frames = make_clip("clip_0000", 5, humanoids=4)
    manifest = write_dataset(tmp_path / "data", "parquet", [frames])
    pairs = sum(int((~f.labels.discontinuity).sum()) for f in frames[1:])  # the factory places some humanoids
    assert manifest.labels["frame_pairs"] == pairs and manifest.labels["boxes"] == 20
    card = (tmp_path / "data" / "README.md").read_text()
    assert "## Labels" in card and "| heading change per frame, degrees |" in card
    assert main(["qa", str(tmp_path / "data"), "-o", str(tmp_path / "qa")]) in (0, 1)
    assert "Labels: how boxes change from frame to frame" in (tmp_path / "qa" / "report.md").read_text()
