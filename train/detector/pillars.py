"""Pillar feature net (PointPillars' simplified PointNet, OpenPCDet's PillarVFE) and its pseudo-images.

Each point is decorated with its offsets from the mean of its pillar's points and from the
pillar's centre (optionally every input divided by its span: `scale_inputs`), goes through Linear +
BatchNorm + ReLU, and every pillar keeps the per-channel maximum over its points. There is no cap on
points or pillars. The loader groups the points into pillars (train.data.collate); decoration and
pooling run on the model's device, with no host synchronisation. The pseudo-images stay sparse
(train.detector.sparse_canvas): the backbone's first convolution reads the pillars directly.
"""

from __future__ import annotations

import torch
from torch import nn

from train.config import POINT_FEATURES, DataConfig, PillarEncoderConfig
from train.detector.registry import PILLAR_ENCODERS
from train.detector.sparse_canvas import SparseCanvas


@PILLAR_ENCODERS.register("pillar_vfe")
class PillarFeatureNet(nn.Module):
    """Points (P, F) grouped into pillars -> pseudo-images (canvases, C, rows, columns), kept sparse."""

    def __init__(self, section: PillarEncoderConfig, data: DataConfig, point_features: int) -> None:
        super().__init__()
        self.rows, self.cols = data.grid_size
        self.pillar_m = data.pillar_size_m
        x0, y0, z0, _, _, z1 = data.point_range_m
        self.register_buffer("origin", torch.tensor([x0, y0, 0.5 * (z0 + z1)]), persistent=False)
        self.channels = section.channels
        half_x, half_y, half_z = 0.5 * (data.point_range_m[3] - x0), 0.5 * (data.point_range_m[4] - y0), 0.5 * (z1 - z0)
        # x, y, z, intensity, then the frame offset (-2, -1, 0) if any; offsets from the pillar's mean and centre
        point = [1 / half_x, 1 / half_y, 1 / half_z, 1.0] + [0.5] * (point_features - POINT_FEATURES)
        offsets = [1 / self.pillar_m, 1 / self.pillar_m, 1 / half_z] * 2
        scale = torch.tensor(point + offsets) if section.scale_inputs else torch.ones(point_features + 6)
        self.register_buffer("input_scale", scale, persistent=False)
        self.linear = nn.Linear(point_features + 6, self.channels, bias=False)
        self.norm = nn.BatchNorm1d(self.channels, eps=1e-3, momentum=0.1)

    def forward(
        self, features: torch.Tensor, pillar: torch.Tensor, point_pillar: torch.Tensor, canvases: int
    ) -> SparseCanvas:
        """Points (P, F), the non-empty pillars' flat cell indices (U,) and each point's pillar (P,) in 0..U-1."""
        cells = self.rows * self.cols
        ones = torch.ones_like(point_pillar, dtype=features.dtype)
        counts = torch.zeros(len(pillar), device=features.device, dtype=features.dtype).index_add_(
            0, point_pillar, ones
        )
        sums = torch.zeros(len(pillar), 3, device=features.device, dtype=features.dtype).index_add_(
            0, point_pillar, features[:, :3]
        )
        mean = sums / counts.clamp(min=1)[:, None]
        within = pillar[point_pillar] % cells
        centre = torch.stack(
            [(within % self.cols).to(features.dtype) + 0.5, (within // self.cols).to(features.dtype) + 0.5], dim=1
        ) * self.pillar_m
        centre = torch.cat([centre, torch.zeros_like(centre[:, :1])], dim=1) + self.origin
        decorated = (
            torch.cat([features, features[:, :3] - mean[point_pillar], features[:, :3] - centre], dim=1)
            * self.input_scale
        )
        point = self.norm(self.linear(decorated))
        # starting from zeros, the maximum is max(0, max_i y_i) = max_i ReLU(y_i): the ReLU, without a copy per point
        pooled = torch.zeros(len(pillar), self.channels, device=features.device, dtype=point.dtype)
        pooled = pooled.scatter_reduce(
            0, point_pillar[:, None].expand(-1, self.channels), point, reduce="amax", include_self=True
        )
        return SparseCanvas(pooled, pillar, canvases, self.rows, self.cols)
