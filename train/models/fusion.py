"""How the frames' features meet (`model.fusion.name`): none (one frame), early (sweeps merged before the
pillars), or late (the paper's module).

Late fusion: per backbone level, the three frames' features (C, 3, H, W) go through a 3x3x3
Conv3d with no temporal padding (3 frames -> 1), BatchNorm and ReLU; the levels are then
concatenated to (3C, H, W).
"""

from __future__ import annotations

import torch
from torch import nn

from train.config import EarlyFusionConfig, LateFusionConfig, NoFusionConfig
from train.models.registry import FUSIONS


class ConcatLevels(nn.Module):
    """One frame (or merged sweeps): the levels concatenated along channels."""

    def forward(self, levels: list[torch.Tensor], batch_size: int) -> torch.Tensor:
        return torch.cat(levels, dim=1)


class LateFusion(nn.Module):
    """Levels of (B * frames, C_i, H, W), frames oldest first per sample -> (B, sum C_i, H, W)."""

    def __init__(self, channels: tuple[int, ...], frames: int) -> None:
        super().__init__()
        self.frames = frames
        self.levels = nn.ModuleList(
            nn.Sequential(
                nn.Conv3d(c, c, (frames, 3, 3), padding=(0, 1, 1), bias=False),
                nn.BatchNorm3d(c, eps=1e-3, momentum=0.1),
                nn.ReLU(),
            )
            for c in channels
        )

    def forward(self, levels: list[torch.Tensor], batch_size: int) -> torch.Tensor:
        fused = []
        for features, fuse in zip(levels, self.levels):
            _, c, h, w = features.shape
            stacked = features.view(batch_size, self.frames, c, h, w).transpose(1, 2)  # (B, C, frames, H, W)
            fused.append(fuse(stacked).squeeze(2))
        return torch.cat(fused, dim=1)


@FUSIONS.register("none", "early")
def _concat(section: NoFusionConfig | EarlyFusionConfig, channels: tuple[int, ...]) -> ConcatLevels:
    return ConcatLevels()


@FUSIONS.register("late")
def _late(section: LateFusionConfig, channels: tuple[int, ...]) -> LateFusion:
    return LateFusion(channels, section.canvases)
