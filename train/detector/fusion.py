"""How the frames' features meet (`model.fusion.name`): single (one frame), early (sweeps merged before the
pillars), or late (the paper's module).

Late fusion: per backbone level, the three frames' features (C, 3, H, W) go through a 3x3x3
Conv3d with no temporal padding (3 frames -> 1), BatchNorm and ReLU; the levels are then
concatenated to (3C, H, W). A 3x3x3 kernel that spans all three frames is a 3x3 Conv2d over the
frames' channels side by side (3C -> C): computed so, with the Conv3d's weights, on a view of the
frames (no copy; one copy in channels-last memory, train.accelerate), it takes about half the CPU
time of torch's Conv3d, and its output (depth 1) is normalised as a 2D map. The val pass
(train.detector.streaming) splits it further: each frame convolved once with each temporal tap, the
window's sum taken from the three frames' terms.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from train.config import EarlyFusionConfig, LateFusionConfig, SingleFrameConfig
from train.detector.registry import FUSIONS


class ConcatLevels(nn.Module):
    """One frame (or merged sweeps): the levels concatenated along channels."""

    def forward(self, levels: list[torch.Tensor], batch_size: int) -> torch.Tensor:
        return torch.cat(levels, dim=1)

    def frame_terms(self, levels: list[torch.Tensor]) -> list[torch.Tensor]:
        """What the fusion takes of each canvas alone (see LateFusion.frame_terms): its levels."""
        return levels

    def fuse_frame_terms(self, terms: list[list[torch.Tensor]]) -> torch.Tensor:
        """`forward` of one sample from its one canvas's `frame_terms`: (1, sum C_i, H, W)."""
        (levels,) = terms
        return torch.cat([level[None] for level in levels], dim=1)


class LateFusion(nn.Module):
    """Levels of (B * frames, C_i, H, W), frames oldest first per sample -> (B, sum C_i, H, W)."""

    def __init__(self, channels: tuple[int, ...], frames: int) -> None:
        super().__init__()
        self.frames = frames
        self.levels = nn.ModuleList(
            nn.Sequential(
                nn.Conv3d(c, c, (frames, 3, 3), padding=(0, 1, 1), bias=False),
                nn.BatchNorm2d(c, eps=1e-3, momentum=0.1),  # the output has depth 1
                nn.ReLU(),
            )
            for c in channels
        )

    def forward(self, levels: list[torch.Tensor], batch_size: int) -> torch.Tensor:
        fused = []
        for features, (conv, norm, relu) in zip(levels, self.levels):
            side_by_side = _side_by_side(features, batch_size, self.frames)
            weight = conv.weight.transpose(1, 2).reshape(conv.out_channels, -1, *conv.kernel_size[1:])
            out = F.conv2d(side_by_side, weight, conv.bias, padding=conv.padding[1:])
            fused.append(relu(norm(out)))
        return torch.cat(fused, dim=1)

    def frame_terms(self, levels: list[torch.Tensor]) -> list[torch.Tensor]:
        """Per level, (N, frames * C_i, H, W): each of N frames convolved with each temporal tap of the
        kernel, tap k (the frame's place in a window, oldest first) in channels k C_i .. (k + 1) C_i. A
        frame in three windows takes each tap once: computed per frame, not per window."""
        terms = []
        for features, (conv, _, _) in zip(levels, self.levels):
            taps = conv.weight.permute(2, 0, 1, 3, 4).reshape(-1, conv.in_channels, *conv.kernel_size[1:])
            terms.append(F.conv2d(features, taps, padding=conv.padding[1:]))
        return terms

    def fuse_frame_terms(self, terms: list[list[torch.Tensor]]) -> torch.Tensor:
        """`forward` of one sample from its frames' `frame_terms` (oldest first, each a list of (frames * C_i,
        H, W)): frame k's tap k summed, then bias, BatchNorm and ReLU; (1, sum C_i, H, W)."""
        fused = []
        for level, (conv, norm, relu) in enumerate(self.levels):
            c = conv.out_channels
            out = sum(frame[level][k * c:(k + 1) * c] for k, frame in enumerate(terms))[None]
            if conv.bias is not None:
                out = out + conv.bias[:, None, None]
            fused.append(relu(norm(out)))
        return torch.cat(fused, dim=1)


def _side_by_side(features: torch.Tensor, batch_size: int, frames: int) -> torch.Tensor:
    """(B * frames, C, H, W), frames oldest first per sample -> (B, frames * C, H, W), channel frame * C + c;
    in the memory format `features` has (a view where it is contiguous, a copy where channels-last)."""
    _, c, h, w = features.shape
    if features.is_contiguous():
        return features.view(batch_size, frames * c, h, w)
    # channels-last: (B, frames, C, H, W) to memory (B, H, W, frames, C)
    per_cell = features.view(batch_size, frames, c, h, w).permute(0, 3, 4, 1, 2).contiguous()
    return per_cell.view(batch_size, h, w, frames * c).permute(0, 3, 1, 2)


@FUSIONS.register("single", "early")
def _concat(section: SingleFrameConfig | EarlyFusionConfig, channels: tuple[int, ...]) -> ConcatLevels:
    return ConcatLevels()


@FUSIONS.register("late")
def _late(section: LateFusionConfig, channels: tuple[int, ...]) -> LateFusion:
    return LateFusion(channels, section.canvases)
