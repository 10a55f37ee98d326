"""The head's target assigner (OpenPCDet's AxisAlignedTargetAssigner, with rotated BEV IoU).

An anchor is positive when the BEV IoU of its box with an object's box at t is at least
`match_iou` (and every object's best anchor is positive), negative below `unmatch_iou`, ignored in
between. A positive's regression targets are the object's K boxes coded against that anchor. It
runs on numpy in the loader's workers (train.data calls it per sample and collates its targets).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from train.config import DenseHeadConfig
from train.detector.anchors import AnchorGrid
from train.detector.box_coder import BoxCoder, direction_bin
from train.geometry import bev_iou

OBJECT_SPAN_M = 3.0  # objects up to ~3 m across are searched for overlapping anchors


@dataclass(frozen=True)
class Targets:
    """One sample's anchor targets; regression only for positives."""

    labels: NDArray[np.int8]  # (N_a,) 1 positive, 0 negative, -1 ignored
    positives: NDArray[np.int64]  # (n,) anchor indices
    deltas: NDArray[np.float32]  # (n, K, 7) residuals of the object's K boxes (oldest first)
    box_mask: NDArray[np.bool_]  # (n, K) the object has a labelled box at that frame
    direction: NDArray[np.int64]  # (n,) direction bin of the box at t


@dataclass(frozen=True)
class BatchTargets:
    """Targets of a batch as torch tensors; `positives` index the flat (B * N_a) anchors."""

    labels: torch.Tensor  # (B, N_a) int8
    positives: torch.Tensor  # (n,) int64
    deltas: torch.Tensor  # (n, K, 7) float32
    box_mask: torch.Tensor  # (n, K) bool
    direction: torch.Tensor  # (n,) int64

    def to(self, device: torch.device, non_blocking: bool = False) -> BatchTargets:
        return BatchTargets(*(t.to(device, non_blocking=non_blocking) for t in self._tensors()))

    def pin_memory(self) -> BatchTargets:
        return BatchTargets(*(t.pin_memory() for t in self._tensors()))

    def _tensors(self) -> tuple[torch.Tensor, ...]:
        return self.labels, self.positives, self.deltas, self.box_mask, self.direction


class AnchorTargetAssigner:
    """Targets of one sample's objects on a grid of anchors; picklable, for the loader's workers."""

    def __init__(self, grid: AnchorGrid, head: DenseHeadConfig, coder: BoxCoder) -> None:
        self.grid, self.coder = grid, coder
        self.match_iou, self.unmatch_iou = head.anchor.match_iou, head.anchor.unmatch_iou
        self.dir_offset_rad = head.dir_offset_rad
        self.boxes = head.tracklet_boxes
        reach_m = 0.5 * (math.hypot(*head.anchor.size_m[:2]) + OBJECT_SPAN_M)
        self._window = math.ceil(reach_m / grid.cell_m)

    def _candidates(self, centres_m: NDArray[np.float32]) -> NDArray[np.int64]:
        """Unique anchor indices in the cells round the given BEV centres (G, 2)."""
        rows, cols, per_cell = self.grid.shape
        col = np.floor((centres_m[:, 0] - self.grid.origin_m[0]) / self.grid.cell_m).astype(np.int64)
        row = np.floor((centres_m[:, 1] - self.grid.origin_m[1]) / self.grid.cell_m).astype(np.int64)
        offsets = np.arange(-self._window, self._window + 1)
        r = (row[:, None, None] + offsets[None, :, None]).clip(0, rows - 1)
        c = (col[:, None, None] + offsets[None, None, :]).clip(0, cols - 1)
        cells = (r * cols + c).reshape(-1)
        return np.unique(cells[:, None] * per_cell + np.arange(per_cell)).reshape(-1)

    def __call__(self, boxes: NDArray[np.float32], box_mask: NDArray[np.bool_]) -> Targets:
        """Targets from the objects' tracklet boxes (G, 3, 7), t last, and which of them are labelled."""
        anchors = self.grid.anchors
        labels = np.zeros(len(anchors), np.int8)
        if len(boxes) == 0:
            none = np.zeros(0, np.int64)
            return Targets(
                labels, none, np.zeros((0, self.boxes, 7), np.float32), np.zeros((0, self.boxes), bool), none
            )
        current = boxes[:, -1]
        candidates = self._candidates(current[:, :2])
        iou = bev_iou(anchors[candidates], current)  # (M, G)
        best_gt = iou.argmax(axis=1)
        best_iou = iou[np.arange(len(candidates)), best_gt]
        labels[candidates[best_iou >= self.unmatch_iou]] = -1
        positive = best_iou >= self.match_iou
        best_anchor = iou.argmax(axis=0)  # each object's best anchor is positive if it overlaps at all
        overlaps = iou[best_anchor, np.arange(len(current))] > 0.0
        positive[best_anchor[overlaps]] = True
        best_gt[best_anchor[overlaps]] = np.nonzero(overlaps)[0]
        index = candidates[positive]
        labels[index] = 1
        objects = best_gt[positive]
        tracklets = boxes[objects][:, -self.boxes:]
        return Targets(
            labels=labels,
            positives=index.astype(np.int64),
            deltas=self.coder.encode(anchors[index], tracklets),
            box_mask=box_mask[objects][:, -self.boxes:],
            direction=direction_bin(current[objects, 6], self.dir_offset_rad),
        )

    def collate(self, targets: list[Targets]) -> BatchTargets:
        """One batch's targets; each sample's positives offset by its place in the batch."""
        anchors = len(self.grid)
        return BatchTargets(
            labels=torch.from_numpy(np.stack([t.labels for t in targets])),
            positives=torch.from_numpy(np.concatenate([b * anchors + t.positives for b, t in enumerate(targets)])),
            deltas=torch.from_numpy(np.concatenate([t.deltas for t in targets])),
            box_mask=torch.from_numpy(np.concatenate([t.box_mask for t in targets])),
            direction=torch.from_numpy(np.concatenate([t.direction for t in targets])),
        )
