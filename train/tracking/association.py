"""Affinity matrices and Hungarian matching with a lower bound.

The paper's affinity of a tracklet and a trajectory is the weighted sum of the 3D DIoU of their
boxes at t-2 and at t-1. Most pairs of 22 players are metres apart and can never reach the lower
bound, so a cheap bound on the DIoU, from centre distances alone, prunes them before the exact
DIoU; the pruned entries are -inf, and matching (which never uses a pair below the bound) gives
exactly what it would on the full matrix.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator
from scipy.optimize import linear_sum_assignment

from simgen.validation import Strict
from train.geometry import diou_3d_pairs

Share = Annotated[float, Field(ge=0.0, le=1.0)]


class AssociationConfig(Strict):
    """`tracklet_diou`: the paper's weighted 3D DIoU of a tracklet's boxes at t-2, t-1 and a
    trajectory's; `iou_3d`: AB3DMOT's 3D IoU of the boxes at t and the Kalman predictions."""

    method: Literal["tracklet_diou", "iou_3d"]
    lower_bound: float = Field(ge=-1.0, le=1.0)  # pairs below it never match (normal trajectories for DIoU)
    dying_lower_bound: float = Field(-0.5, ge=-1.0, le=1.0)  # tracklet_diou: for dying trajectories
    # tracklet_diou: of the DIoU at t-2 and at t-1, summing to 1 so that the bounds keep DIoU's scale. The
    # paper does not give them; t-1 weighs more because both its boxes come from later, better-supported
    # regressions (the trajectory's box at t-1 was regressed as a tracklet's current box).
    weights: tuple[Share, Share] = (0.4, 0.6)
    # matched in turn: normal, dying (at dying_lower_bound), then new tracks; off: all at once (AB3DMOT)
    cascade: bool = True

    @model_validator(mode="after")
    def _sum(self) -> AssociationConfig:
        if abs(sum(self.weights) - 1.0) > 1e-6:
            raise ValueError(f"'association.weights': {self.weights[0]:g} + {self.weights[1]:g} is not 1")
        return self


def _half_diagonals(boxes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """BEV and 3D centre-to-corner distances in metres of boxes (..., 7)."""
    bev = 0.5 * np.hypot(boxes[..., 3], boxes[..., 4])
    return bev, 0.5 * np.sqrt(boxes[..., 3] ** 2 + boxes[..., 4] ** 2 + boxes[..., 5] ** 2)


def diou_upper_bound(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """An upper bound on the DIoU of boxes a (..., 7) and b (..., 7), broadcast.

    With d the centre distance and R_a, R_b the centre-to-corner distances, the farthest corner
    pair is at most d + R_a + R_b apart, so the penalty is at least d^2 / (d + R_a + R_b)^2; the IoU
    is 0 where the BEV circumscribed circles are apart and at most 1 elsewhere.
    """
    bev_a, reach_a = _half_diagonals(a)
    bev_b, reach_b = _half_diagonals(b)
    gap_bev_sq = (a[..., 0] - b[..., 0]) ** 2 + (a[..., 1] - b[..., 1]) ** 2
    gap = np.sqrt(gap_bev_sq + (a[..., 2] - b[..., 2]) ** 2)
    far = np.where(gap > 0.0, gap / np.maximum(gap + reach_a + reach_b, 1e-300), 0.0)
    may_overlap = gap_bev_sq < (bev_a + bev_b) ** 2
    return may_overlap - far * far


def _frames_first(boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Boxes (M, F, 7) as (F, M, 7), each column [..., i] contiguous: numpy's loops then run over M."""
    return np.ascontiguousarray(boxes.transpose(2, 1, 0)).transpose(1, 2, 0)


def diou_affinity(
    tracklet_boxes: NDArray[np.float64],
    trajectory_boxes: NDArray[np.float64],
    weights: tuple[float, ...],
    lower_bound: float | NDArray[np.float64],
) -> NDArray[np.float64]:
    """(N, K) weighted sum over F frames of the DIoU of tracklets (N, F, 7) and trajectories (K, F, 7).

    Entries that cannot reach lower_bound (a number, or one per trajectory) are -inf.
    """
    n, k = len(tracklet_boxes), len(trajectory_boxes)
    affinity = np.full((n, k), -np.inf)
    if n == 0 or k == 0:
        return affinity
    a, b = _frames_first(tracklet_boxes)[:, :, None], _frames_first(trajectory_boxes)[:, None]  # (F, N | 1, 1 | K, 7)
    bound = np.ascontiguousarray(diou_upper_bound(a, b).transpose(1, 2, 0)) @ np.asarray(weights)
    rows, cols = np.nonzero(bound >= lower_bound)
    if len(rows):
        frames = len(weights)
        diou = diou_3d_pairs(tracklet_boxes[rows].reshape(-1, 7), trajectory_boxes[cols].reshape(-1, 7))
        affinity[rows, cols] = diou.reshape(-1, frames) @ np.asarray(weights)
    return affinity


def match(affinity: NDArray[np.float64], lower_bound: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Rows and columns of the Hungarian matching that maximises the summed margin above lower_bound.

    Pairs below lower_bound are never matched: a gated maximum-weight matching, with weights
    ``affinity - lower_bound``, so a pair below the bound neither matches nor sways other pairs.
    """
    allowed = affinity >= lower_bound
    if not allowed.any():
        return np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp)
    rows, cols = linear_sum_assignment(np.where(allowed, lower_bound - affinity, 0.0))
    keep = allowed[rows, cols]
    return rows[keep], cols[keep]
