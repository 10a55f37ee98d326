"""Greedy non-maximum suppression on exact rotated BEV IoU (train.geometry)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from train.geometry import bev_iou


def nms_bev(boxes: NDArray[np.float32], scores: NDArray[np.float32], iou_threshold: float, keep_max: int) -> NDArray[np.int64]:
    """Indices of kept boxes (N, 7), best score first: a box goes when it overlaps a kept one by more than the threshold."""
    order = np.argsort(-scores, kind="stable")
    overlap = bev_iou(boxes[order], boxes[order]) > iou_threshold
    suppressed = np.zeros(len(order), bool)
    kept = []
    for i in range(len(order)):
        if suppressed[i]:
            continue
        kept.append(order[i])
        if len(kept) == keep_max:
            break
        suppressed |= overlap[i]
    return np.asarray(kept, np.int64)
