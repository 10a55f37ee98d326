"""KITTI-style average precision of 3D boxes, in bird's-eye view (BEV) and 3D, on exact rotated IoU.

Per frame, detections in descending score are matched greedily, each to the still unmatched
ground-truth box of highest IoU (train.geometry: exact rotated BEV or 3D IoU) if that IoU is at
least the threshold (0.5): a true positive, else a false positive. Over all frames, detections are
ranked by score to give precision and recall; the interpolated precision at recall r is the
largest precision at any recall >= r (0 if recall never reaches r). AP is the mean interpolated
precision over KITTI's recall points: 40 (r = 1/40, ..., 1; KITTI since 2019) or 11 (r = 0, 0.1,
..., 1; the original devkit), in percent. There are no difficulty levels or DontCare regions.
With fewer than about 40 ground-truth boxes AP moves in large steps.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from train.geometry import bev_iou, iou_3d

IOU_FUNCTIONS: dict[str, Callable[[NDArray, NDArray], NDArray[np.float64]]] = {"bev": bev_iou, "3d": iou_3d}
RECALL_POINTS = (40, 11)


@dataclass(frozen=True)
class FrameBoxes:
    """One frame's detections and ground truth for one box of the tracklet (t, t-1 or t-2)."""

    boxes: NDArray[np.float32]  # (N, 7) detected
    scores: NDArray[np.float32]  # (N,)
    truth: NDArray[np.float32]  # (G, 7) labelled


def match_frame(frame: FrameBoxes, iou_kind: str, threshold: float) -> NDArray[np.bool_]:
    """(N,) True for each detection that is a true positive, in the input order."""
    tp = np.zeros(len(frame.boxes), bool)
    if len(frame.boxes) == 0 or len(frame.truth) == 0:
        return tp
    iou = IOU_FUNCTIONS[iou_kind](frame.boxes, frame.truth)
    taken = np.zeros(len(frame.truth), bool)
    for i in np.argsort(-frame.scores, kind="stable"):
        free = np.where(taken, -1.0, iou[i])
        best = int(free.argmax())
        if free[best] >= threshold:
            tp[i], taken[best] = True, True
    return tp


def average_precision(scores: NDArray[np.float32], tp: NDArray[np.bool_], num_truth: int, recall_points: int) -> float:
    """AP in percent from all detections' scores and true-positive flags and the ground-truth count."""
    if recall_points not in RECALL_POINTS:
        raise ValueError(f"recall_points must be one of {RECALL_POINTS}, got {recall_points}")
    if num_truth == 0:
        return float("nan")
    if len(scores) == 0:
        return 0.0
    order = np.argsort(-scores, kind="stable")
    hits = np.cumsum(tp[order])
    recall = hits / num_truth
    precision = hits / np.arange(1, len(order) + 1)
    best_after = np.maximum.accumulate(precision[::-1])[::-1]  # interpolated: best at this recall or beyond
    levels = np.linspace(1 / 40, 1, 40) if recall_points == 40 else np.linspace(0, 1, 11)
    at = np.searchsorted(recall, levels - 1e-12, side="left")  # first rank reaching each level
    reached = at < len(order)
    return float(100.0 * np.where(reached, best_after[np.minimum(at, len(order) - 1)], 0.0).mean())


def detection_ap(frames: Sequence[FrameBoxes], iou_kind: str, threshold: float = 0.5, recall_points: int = 40) -> float:
    """AP in percent over frames, with IoU `iou_kind` ('bev' or '3d') at `threshold`."""
    tps = [match_frame(f, iou_kind, threshold) for f in frames]
    scores = np.concatenate([f.scores for f in frames]) if frames else np.zeros(0, np.float32)
    tp = np.concatenate(tps) if tps else np.zeros(0, bool)
    return average_precision(scores, tp, sum(len(f.truth) for f in frames), recall_points)
