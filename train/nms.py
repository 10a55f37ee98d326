"""Greedy non-maximum suppression on exact rotated BEV IoU (train.geometry) or on BEV centre distance."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from train.geometry import bev_iou


def _greedy(order: NDArray[np.int64], suppresses: NDArray[np.bool_], keep_max: int) -> NDArray[np.int64]:
    """Kept indices, best first, of boxes in `order` (best first), where suppresses[i, j] (in that order)
    says that keeping box i removes box j."""
    suppressed = np.zeros(len(order), bool)
    kept = []
    for i in range(len(order)):
        if suppressed[i]:
            continue
        kept.append(order[i])
        if len(kept) == keep_max:
            break
        suppressed |= suppresses[i]
    return np.asarray(kept, np.int64)


def nms_bev(
    boxes: NDArray[np.float32], scores: NDArray[np.float32], iou_threshold: float, keep_max: int
) -> NDArray[np.int64]:
    """Indices of kept boxes (N, 7), best score first: a box goes when it overlaps a kept one by more than the
    threshold."""
    order = np.argsort(-scores, kind="stable")
    return _greedy(order, bev_iou(boxes[order], boxes[order]) > iou_threshold, keep_max)


def nms_centre(
    boxes: NDArray[np.float32], scores: NDArray[np.float32], distance_m: float, keep_max: int
) -> NDArray[np.int64]:
    """Indices of kept boxes (N, 7), best score first: a box goes when its BEV centre is closer than
    distance_m to a kept one's."""
    order = np.argsort(-scores, kind="stable")
    centres = np.asarray(boxes, np.float64)[order, :2]
    gap = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    return _greedy(order, gap < distance_m, keep_max)
