"""Score thresholds at evenly spaced recall levels, the rule KITTI's evaluation and AB3DMOT share.

Walking the true positives' scores from the highest, level k/L (k = 0, 1, ...) takes the first
score whose recall is nearer to k/L than the next score's; the last true positive's score always
stands, so the level nearest the maximum recall is credited even when that recall falls short of
it. (kitti_object_eval_python's and AB3DMOT's `get_thresholds`.)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def level_thresholds(tp_scores: Sequence[float], n_gt: int, levels: int) -> list[tuple[float, float]]:
    """(score threshold, recall level k/levels) for k = 0, 1, ... as far as the true positives reach."""
    scores = np.sort(np.asarray(tp_scores, dtype=np.float64))[::-1]
    out: list[tuple[float, float]] = []
    for i, score in enumerate(scores):
        current = len(out) / levels
        here, after = (i + 1) / n_gt, (i + 2) / n_gt
        if i < len(scores) - 1 and after - current < current - here:
            continue
        out.append((float(score), current))
    return out
