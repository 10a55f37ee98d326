"""SSD-style head: per cell and anchor, a class score, K boxes (7 residuals each) and a direction."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn


@dataclass(frozen=True)
class HeadOutput:
    """Per sample, anchors in (row, column, anchor) order."""

    scores: torch.Tensor  # (B, N_a) logits
    deltas: torch.Tensor  # (B, N_a, K, 7) residuals against the anchor, oldest box first
    direction: torch.Tensor  # (B, N_a, 2) logits


class DetectionHead(nn.Module):
    def __init__(self, inputs: int, anchors_per_cell: int, boxes: int) -> None:
        super().__init__()
        self.anchors, self.boxes = anchors_per_cell, boxes
        self.score = nn.Conv2d(inputs, anchors_per_cell, 1)
        self.box = nn.Conv2d(inputs, anchors_per_cell * boxes * 7, 1)
        self.direction = nn.Conv2d(inputs, anchors_per_cell * 2, 1)
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
