"""The dense head (SSD style, OpenPCDet's AnchorHeadSingle) with its anchors, box coder and target assigner.

Per anchor: a score, K boxes (t-2, t-1, t for tracklets, or t alone) as residuals against the
anchor, and a direction bin. The anchors, the coder and the assigner are built from the same
config section, so training targets and decoding always agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from train.config import Backbone2dConfig, DataConfig, HeadConfig
from train.models.anchors import anchor_grid
from train.models.registry import BOX_CODERS, HEADS
from train.models.target_assigner import AnchorTargetAssigner


@dataclass(frozen=True)
class HeadOutput:
    """Per sample, anchors in (row, column, anchor) order."""

    scores: torch.Tensor  # (B, N_a) logits
    deltas: torch.Tensor  # (B, N_a, K, 7) residuals against the anchor, oldest box first
    direction: torch.Tensor  # (B, N_a, 2) logits

    def float(self) -> HeadOutput:
        """float32 copies (the loss and decoding run in float32 under autocast)."""
        return HeadOutput(self.scores.float(), self.deltas.float(), self.direction.float())


@HEADS.register("anchor_head")
class DetectionHead(nn.Module):
    def __init__(self, section: HeadConfig, data: DataConfig, backbone: Backbone2dConfig, inputs: int) -> None:
        super().__init__()
        grid = anchor_grid(section.anchor, data, backbone.output_stride)
        self.box_coder = BOX_CODERS.build(section.box_coder)
        self.assigner = AnchorTargetAssigner(grid, section, self.box_coder)
        self.register_buffer("anchors", torch.from_numpy(grid.anchors), persistent=False)  # (N_a, 7)
        per_cell, self.boxes = len(section.anchor.yaws_rad), section.tracklet_boxes
        self.score = nn.Conv2d(inputs, per_cell, 1)
        self.box = nn.Conv2d(inputs, per_cell * self.boxes * 7, 1)
        self.direction = nn.Conv2d(inputs, per_cell * 2, 1)
        nn.init.constant_(self.score.bias, -math.log((1 - 0.01) / 0.01))  # prior 0.01, as RetinaNet
        nn.init.normal_(self.box.weight, std=0.001)

    def forward(self, features: torch.Tensor) -> HeadOutput:
        b = features.shape[0]

        def per_anchor(x: torch.Tensor, *tail: int) -> torch.Tensor:
            return x.permute(0, 2, 3, 1).reshape(b, -1, *tail)

        return HeadOutput(
            scores=per_anchor(self.score(features), 1)[..., 0],
            deltas=per_anchor(self.box(features), self.boxes, 7),
            direction=per_anchor(self.direction(features), 2),
        )
