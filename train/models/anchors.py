"""Anchors on the output grid and their targets: two per cell (0 and 90 degrees), SSD style.

Anchors are ordered (row along y, column along x, anchor), the order of the head's outputs. An
anchor is positive when the BEV IoU of its box with an object's box at t is at least `match_iou`
(and every object's best anchor is positive), negative below `unmatch_iou`, ignored in between.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from train.config import DetectorConfig
from train.geometry import bev_iou
from train.models.box_coder import direction_bin, encode


@dataclass(frozen=True)
class Targets:
    """One sample's anchor targets; regression only for positives."""

    labels: NDArray[np.int8]  # (N_a,) 1 positive, 0 negative, -1 ignored
    positives: NDArray[np.int64]  # (n,) anchor indices
    deltas: NDArray[np.float32]  # (n, K, 7) residuals of the object's K boxes (oldest first)
    box_mask: NDArray[np.bool_]  # (n, K) the object has a labelled box at that frame
    direction: NDArray[np.int64]  # (n,) direction bin of the box at t


class AnchorGrid:
    """The anchors (N_a, 7) of a config's output grid and their assignment to objects."""

    def __init__(self, config: DetectorConfig) -> None:
        model, data = config.model, config.data
        self.cell_m = data.pillar_size_m * model.backbone.output_stride
        rows, cols = (n // model.backbone.output_stride for n in data.grid_size)
        self.shape = (rows, cols, len(model.anchor.yaws_rad))
        x0, y0 = data.point_range_m[0], data.point_range_m[1]
        ys = y0 + (np.arange(rows) + 0.5) * self.cell_m
        xs = x0 + (np.arange(cols) + 0.5) * self.cell_m
        grid_y, grid_x, yaw = np.meshgrid(ys, xs, model.anchor.yaws_rad, indexing="ij")
        size = np.broadcast_to(np.asarray(model.anchor.size_m), grid_x.shape + (3,))
        self.anchors = np.concatenate(
            [np.stack([grid_x, grid_y, np.full_like(grid_x, model.anchor.z_m)], -1), size, yaw[..., None]], axis=-1
        ).reshape(-1, 7).astype(np.float32)
        self.origin_m = (x0, y0)
        self.match_iou, self.unmatch_iou = model.anchor.match_iou, model.anchor.unmatch_iou
        self.dir_offset_rad = model.dir_offset_rad
        self.boxes = model.tracklet_boxes
        reach_m = 0.5 * (math.hypot(*model.anchor.size_m[:2]) + 3.0)  # objects up to ~3 m across
        self._window = int(math.ceil(reach_m / self.cell_m))

    def __len__(self) -> int:
        return len(self.anchors)

    def _candidates(self, centres_m: NDArray[np.float32]) -> NDArray[np.int64]:
        """Unique anchor indices in the cells round the given BEV centres (G, 2)."""
        rows, cols, per_cell = self.shape
        col = np.floor((centres_m[:, 0] - self.origin_m[0]) / self.cell_m).astype(np.int64)
        row = np.floor((centres_m[:, 1] - self.origin_m[1]) / self.cell_m).astype(np.int64)
        offsets = np.arange(-self._window, self._window + 1)
        r = (row[:, None, None] + offsets[None, :, None]).clip(0, rows - 1)
        c = (col[:, None, None] + offsets[None, None, :]).clip(0, cols - 1)
        cells = (r * cols + c).reshape(-1)
        return np.unique(cells[:, None] * per_cell + np.arange(per_cell)).reshape(-1)

    def assign(self, boxes: NDArray[np.float32], box_mask: NDArray[np.bool_]) -> Targets:
        """Targets from the objects' tracklet boxes (G, 3, 7), t last, and which of them are labelled."""
        labels = np.zeros(len(self.anchors), np.int8)
        if len(boxes) == 0:
            none = np.zeros(0, np.int64)
            return Targets(labels, none, np.zeros((0, self.boxes, 7), np.float32), np.zeros((0, self.boxes), bool), none)
        current = boxes[:, -1]
        candidates = self._candidates(current[:, :2])
        iou = bev_iou(self.anchors[candidates], current)  # (M, G)
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
            deltas=encode(self.anchors[index], tracklets),
            box_mask=box_mask[objects][:, -self.boxes:],
            direction=direction_bin(current[objects, 6], self.dir_offset_rad),
        )
