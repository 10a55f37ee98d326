"""The dense head (SSD style, OpenPCDet's AnchorHeadSingle) with its anchors, box coder and target assigner.

Per anchor: a score, K boxes (t-2, t-1, t for tracklets, or t alone) as residuals against the
anchor, and a direction bin. The anchors, the coder and the assigner are built from the same
config section, so training targets and decoding always agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from train.config import Backbone2dConfig, DataConfig, DenseHeadConfig
from train.detector.anchors import anchor_grid
from train.detector.registry import BOX_CODERS, HEADS
from train.detector.target_assigner import AnchorTargetAssigner


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
    def __init__(self, section: DenseHeadConfig, data: DataConfig, backbone: Backbone2dConfig, inputs: int) -> None:
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

    def anchor_scores(self, features: torch.Tensor) -> torch.Tensor:
        """(B, N_a) score logits alone, as `forward` gives them."""
        return self.score(features).permute(0, 2, 3, 1).reshape(features.shape[0], -1)

    def anchor_boxes(self, features: torch.Tensor, anchors: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Deltas (K, K_boxes, 7) and direction logits (K, 2) of one sample's (C, H, W) `anchors` (K,)
        alone, as `forward` gives them: the 1 x 1 convolutions at those cells only."""
        per_cell = self.score.out_channels
        cell, within = anchors // per_cell, anchors % per_cell
        at = features.flatten(1)[:, cell].T  # (K, C)
        pick = torch.arange(len(anchors), device=anchors.device)
        box = F.linear(at, self.box.weight.flatten(1), self.box.bias).view(len(anchors), per_cell, self.boxes, 7)
        direction = F.linear(at, self.direction.weight.flatten(1), self.direction.bias).view(len(anchors), per_cell, 2)
        return box[pick, within], direction[pick, within]
