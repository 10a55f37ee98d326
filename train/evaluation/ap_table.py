"""Detection AP of a model on a dataset split, for each box of the tracklet.

AP rows: each box of the tracklet (t, t-1, t-2), IoU 0.5 in BEV and 3D and pitch-plane centre
distance within 0.25, 0.5 and 1 m, R40 and R11, on all labelled boxes and on the *visible* ones
(at least one point in t-2..t; the others are ignored: a detection on one counts neither way).
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

import simgen.datasets
from simgen.atomic import atomic_path
from train.config import TRACKLET_FRAMES, DetectorConfig
from train.data import Sample
from train.detector.inference import predict
from train.detector.model import Detector
from train.detector.postprocess import Detections
from train.evaluation.detection import RECALL_POINTS, FrameBoxes, detection_aps, similarities

IOU_THRESHOLD = 0.5
CENTRE_THRESHOLDS_M = (0.25, 0.5, 1.0)
TRUTH_SETS = ("all", "visible")
MEANINGFUL_TRUTH = 40  # fewer ground-truth boxes make AP coarse


@dataclass(frozen=True)
class ApRow:
    box: str  # "t", "t-1" or "t-2"
    iou: str  # "bev", "3d" (IoU >= threshold) or "centre" (BEV centre distance <= threshold metres)
    recall_points: int  # 40 or 11
    ap: float  # percent
    truth: int  # ground-truth boxes counted
    detections: int
    threshold: float = IOU_THRESHOLD
    truth_set: str = "all"  # or "visible"


def box_name(offset: int) -> str:
    return "t" if offset == 0 else f"t{offset}"


def average_precisions(
    results: list[tuple[Sample, Detections]], visible: list[NDArray[np.bool_]] | None = None
) -> list[ApRow]:
    """AP of the boxes at t and, for tracklet models, at t-1 and t-2: BEV and 3D IoU, centre distance,
    40 and 11 points; on all labelled boxes and, given `visible` (per sample, (G,)), on the visible ones."""
    boxes = results[0][1].boxes.shape[1] if results else 1
    measures = [("bev", IOU_THRESHOLD), ("3d", IOU_THRESHOLD)] + [("centre", d) for d in CENTRE_THRESHOLDS_M]
    rows = []
    for k in range(boxes):
        offset = k - boxes + 1
        at = TRACKLET_FRAMES - 1 + offset
        similarity: dict[str, list] = {}  # per kind, the same for every truth set (they differ in what is ignored)
        for truth_set in TRUTH_SETS[: 1 if visible is None else 2]:
            frames = [
                FrameBoxes(d.boxes[:, k], d.scores, s.boxes[s.box_mask[:, at], at],
                           None if truth_set == "all" else ~visible[i][s.box_mask[:, at]])
                for i, (s, d) in enumerate(results)
            ]
            truth, count = sum(f.counted_truth for f in frames), sum(len(f.boxes) for f in frames)
            for kind, threshold in measures:
                if kind not in similarity:
                    similarity[kind] = similarities(frames, kind)
                aps = detection_aps(frames, kind, threshold, RECALL_POINTS, similarity[kind])
                rows += [ApRow(box_name(offset), kind, points, ap, truth, count, threshold, truth_set)
                         for points, ap in zip(RECALL_POINTS, aps)]
    return sorted(rows, key=lambda r: (r.truth_set, r.box != "t", r.box, r.iou, r.threshold, r.recall_points))


def _points_in_boxes(points_m: NDArray[np.float32], boxes: NDArray[np.float32]) -> NDArray[np.int64]:
    """(H,) points (P, 3) inside each box (H, 7)."""
    rel = np.asarray(points_m, np.float64)[None] - np.asarray(boxes, np.float64)[:, None, :3]  # (H, P, 3)
    cos, sin = np.cos(boxes[:, 6])[:, None], np.sin(boxes[:, 6])[:, None]
    along, across = cos * rel[..., 0] + sin * rel[..., 1], -sin * rel[..., 0] + cos * rel[..., 1]
    half = 0.5 * np.asarray(boxes, np.float64)[:, None, 3:6]
    inside = (np.abs(along) <= half[..., 0]) & (np.abs(across) <= half[..., 1]) & (np.abs(rel[..., 2]) <= half[..., 2])
    return inside.sum(axis=1)


def _frame_points(dataset: simgen.datasets.Dataset, clip: str, index: int) -> dict[int, int]:
    """Track id -> points on that object in one frame (the labels' count, else the points in its box)."""
    frame = dataset.frame(clip, index)
    counts = frame.num_points if frame.num_points is not None else _points_in_boxes(frame.points_m, frame.boxes)
    return dict(zip(np.asarray(frame.track_id).tolist(), np.asarray(counts).tolist()))


def visible_objects(dataset: simgen.datasets.Dataset, samples: list[Sample]) -> list[NDArray[np.bool_]]:
    """Per sample, (G,): its objects with at least one point in frames t-2..t."""
    cache: dict[tuple[str, int], dict[int, int]] = {}
    out = []
    for sample in samples:
        seen = np.zeros(len(sample.track_id), bool)
        for index in range(sample.index - TRACKLET_FRAMES + 1, sample.index + 1):
            key = (sample.clip, index)
            if key not in cache:
                cache[key] = _frame_points(dataset, *key)
            seen |= np.array([cache[key].get(int(t), 0) > 0 for t in sample.track_id], bool)
        out.append(seen)
    return out


def write_ap_csv(path: Path, rows: list[ApRow], extra: dict[str, str]) -> None:
    """The rows as CSV, each with the `extra` columns first; written atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow([*extra, "truth_set", "box", "iou", "threshold", "recall_points", "ap", "truth", "detections"])
        for r in rows:
            writer.writerow([*extra.values(), r.truth_set, r.box, r.iou, r.threshold, r.recall_points, f"{r.ap:.2f}",
                             r.truth, r.detections])


def format_ap_table(rows: list[ApRow]) -> str:
    lines = ["truth    box  match          AP@R40  AP@R11  truth  detections"]
    for r in rows:
        if r.recall_points == 40:
            key = (r.truth_set, r.box, r.iou, r.threshold)
            r11 = next(x.ap for x in rows if (x.truth_set, x.box, x.iou, x.threshold, x.recall_points) == (*key, 11))
            lines.append(f"{r.truth_set:<8} {r.box:<4} {measure_name(r):<14} {r.ap:6.2f}  {r11:6.2f}  {r.truth:5d}  "
                         f"{r.detections:10d}")
    fewest = min((r.truth for r in rows), default=0)
    if fewest < MEANINGFUL_TRUTH:
        lines.append(f"note: {fewest} ground-truth boxes; AP moves in large steps under about {MEANINGFUL_TRUTH}")
    return "\n".join(lines)


@dataclass(frozen=True)
class EvalResult:
    rows: list[ApRow]
    frames_per_s: float  # inference, loading included


def evaluate(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device,
             progress: bool = True) -> EvalResult:
    start = time.perf_counter()
    results = list(predict(model, config, dataset, split, device, progress))
    visible = visible_objects(simgen.datasets.open(dataset), [s for s, _ in results])
    return EvalResult(average_precisions(results, visible), len(results) / (time.perf_counter() - start))


def measure_name(row: ApRow) -> str:
    """`bev IoU 0.5`, `3d IoU 0.5` or `centre 0.25 m`."""
    return f"centre {row.threshold:g} m" if row.iou == "centre" else f"{row.iou} IoU {row.threshold:g}"


def mean_ap(rows: list[ApRow], iou: str, recall_points: int = 40, box: str = "t", threshold: float = IOU_THRESHOLD,
            truth_set: str = "all") -> float:
    key = (box, iou, recall_points, threshold, truth_set)
    return next((r.ap for r in rows if (r.box, r.iou, r.recall_points, r.threshold, r.truth_set) == key), float(np.nan))
