"""Greedy non-maximum suppression on exact rotated BEV IoU (train.geometry) or on BEV centre distance.

The exact rotated IoU costs microseconds a pair, and a frame's few hundred candidates make
thousands of overlapping pairs, so `nms_bev` decides what it can from bounds first: two boxes'
intersection holds the overlap of their inscribed discs and lies in that of their circumscribed
ones (and in the smaller box), so those give an IoU below and above the exact one. A pair above
the threshold by its lower bound suppresses, one below by its upper bound does not, and only the
others, and only where the box that would suppress is kept, get the exact IoU: the greedy pass
is run again with each round's new answers until every such pair is known.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from train.geometry import bev_iou_pairs

_BOUND_MARGIN = 1e-9  # a bound decides a pair only this far from the threshold (float64 rounding)


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


def _disc_overlap(r1: NDArray[np.float64], r2: NDArray[np.float64], gap: NDArray[np.float64]) -> NDArray[np.float64]:
    """Area in m^2 of the intersection of discs of radii r1, r2 (metres) whose centres are `gap` metres apart."""
    gap = np.maximum(gap, 1e-300)
    cos1 = np.clip((gap * gap + r1 * r1 - r2 * r2) / (2 * gap * r1), -1.0, 1.0)
    cos2 = np.clip((gap * gap + r2 * r2 - r1 * r1) / (2 * gap * r2), -1.0, 1.0)
    kite = (-gap + r1 + r2) * (gap + r1 - r2) * (gap - r1 + r2) * (gap + r1 + r2)
    lens = r1 * r1 * np.arccos(cos1) + r2 * r2 * np.arccos(cos2) - 0.5 * np.sqrt(np.maximum(kite, 0.0))
    inside = np.pi * np.minimum(r1, r2) ** 2
    return np.where(gap >= r1 + r2, 0.0, np.where(gap <= np.abs(r1 - r2), inside, lens))


def nms_bev(
    boxes: NDArray[np.float32], scores: NDArray[np.float32], iou_threshold: float, keep_max: int
) -> NDArray[np.int64]:
    """Indices of kept boxes (N, 7), best score first: a box goes when it overlaps a kept one by more than the
    threshold."""
    order = np.argsort(-scores, kind="stable")
    ranked = np.asarray(boxes, np.float64)[order]
    area = ranked[:, 3] * ranked[:, 4]
    outer, inner = 0.5 * np.hypot(ranked[:, 3], ranked[:, 4]), 0.5 * np.minimum(ranked[:, 3], ranked[:, 4])
    gaps = np.hypot(ranked[:, None, 0] - ranked[None, :, 0], ranked[:, None, 1] - ranked[None, :, 1])
    first, second = np.nonzero(np.triu(gaps < outer[:, None] + outer[None], 1))  # pairs that may overlap, better first
    gap, total = gaps[first, second], area[first] + area[second]
    low = _disc_overlap(inner[first], inner[second], gap)
    high = np.minimum(_disc_overlap(outer[first], outer[second], gap), np.minimum(area[first], area[second]))
    sure = low / np.maximum(total - low, 1e-300) > iou_threshold + _BOUND_MARGIN
    unsure = ~sure & (high / np.maximum(total - high, 1e-300) >= iou_threshold - _BOUND_MARGIN)
    suppresses = np.zeros((len(ranked), len(ranked)), bool)
    suppresses[first[sure], second[sure]] = True
    first, second = first[unsure], second[unsure]
    while True:
        kept = _greedy(np.arange(len(ranked)), suppresses, keep_max)
        now = np.isin(first, kept)
        if not now.any():
            return order[kept]
        suppresses[first[now], second[now]] = bev_iou_pairs(ranked[first[now]], ranked[second[now]]) > iou_threshold
        first, second = first[~now], second[~now]


def nms_centre(
    boxes: NDArray[np.float32], scores: NDArray[np.float32], distance_m: float, keep_max: int
) -> NDArray[np.int64]:
    """Indices of kept boxes (N, 7), best score first: a box goes when its BEV centre is closer than
    distance_m to a kept one's."""
    order = np.argsort(-scores, kind="stable")
    centres = np.asarray(boxes, np.float64)[order, :2]
    gap = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    return _greedy(order, gap < distance_m, keep_max)
