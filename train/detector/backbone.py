"""PointPillars' 2D backbone (OpenPCDet's BaseBEVBackbone): three top-down conv blocks, each upsampled to one size."""

from __future__ import annotations

import torch
from torch import nn

from train.config import Backbone2dConfig
from train.detector.registry import BACKBONES_2D
from train.detector.sparse_canvas import SparseCanvas, sparse_conv2d


def _conv(inputs: int, outputs: int, stride: int = 1) -> list[nn.Module]:
    return [
        nn.Conv2d(inputs, outputs, 3, stride, 1, bias=False),
        nn.BatchNorm2d(outputs, eps=1e-3, momentum=0.1),
        nn.ReLU(),
    ]


def _up(inputs: int, outputs: int, stride: int) -> nn.Sequential:
    conv = (
        nn.ConvTranspose2d(inputs, outputs, stride, stride, bias=False)
        if stride > 1
        else nn.Conv2d(inputs, outputs, 1, bias=False)
    )
    return nn.Sequential(conv, nn.BatchNorm2d(outputs, eps=1e-3, momentum=0.1), nn.ReLU())


@BACKBONES_2D.register("pointpillars")
class Backbone(nn.Module):
    """(N, C_in, rows, columns) -> three levels (N, upsample_channels[i], rows / s, columns / s)."""

    def __init__(self, config: Backbone2dConfig, inputs: int) -> None:
        super().__init__()
        blocks = []
        for layers, stride, channels in zip(config.layers, config.strides, config.channels):
            modules = _conv(inputs, channels, stride)
            for _ in range(layers - 1):
                modules += _conv(channels, channels)
            blocks.append(nn.Sequential(*modules))
            inputs = channels
        self.blocks = nn.ModuleList(blocks)
        self.ups = nn.ModuleList(
            _up(c, u, s) for c, u, s in zip(config.channels, config.upsample_channels, config.upsample_strides)
        )

    def forward(self, image: torch.Tensor | SparseCanvas) -> list[torch.Tensor]:
        """Pseudo-images, dense or sparse (the first convolution then reads the pillars alone)."""
        levels = []
        for block, up in zip(self.blocks, self.ups):
            if isinstance(image, SparseCanvas):
                image = block[1:](sparse_conv2d(image, block[0]))
            else:
                image = block(image)
            levels.append(up(image))
        return levels
