"""The detector a config describes, assembled from named parts as OpenPCDet does.

`model.pillar_encoder`, `model.backbone_2d`, `model.fusion` and `model.head` each name a part
registered in train.detector.registry: the paper's single-frame, early- and late-fusion models are
three configs, not three code paths.
"""

from __future__ import annotations

from typing import Protocol

import torch
from torch import nn

from train.config import POINT_FEATURES, DetectorConfig
from train.detector import backbone, fusion, head, pillars  # noqa: F401 - their parts register themselves
from train.detector.head import HeadOutput
from train.detector.registry import BACKBONES_2D, FUSIONS, HEADS, PILLAR_ENCODERS


class PillarBatch(Protocol):
    """What the detector reads of a batch (train.data.Batch)."""

    features: torch.Tensor  # (P, F) points of all samples
    pillar: torch.Tensor  # (U,) int64 the non-empty pillars, flat index into (B * canvases * rows * columns)
    point_pillar: torch.Tensor  # (P,) int64 each point's pillar, 0 .. U - 1
    batch_size: int


class Detector(nn.Module):
    """Batch -> per-anchor scores, K boxes and direction logits: pillar encoder, 2D backbone, fusion, head.

    The backbone runs on `fusion.canvases` pseudo-images per sample (late: one per frame; early:
    the sweeps merged, with a time channel; single: frame t), and the fusion turns its levels into
    the head's input.
    """

    def __init__(self, config: DetectorConfig) -> None:
        super().__init__()
        model = config.model
        self.canvases = model.fusion.canvases
        point_features = POINT_FEATURES + int(model.fusion.time_channel)
        self.pillar_encoder = PILLAR_ENCODERS.build(model.pillar_encoder, config.data, point_features)
        self.backbone_2d = BACKBONES_2D.build(model.backbone_2d, model.pillar_encoder.channels)
        channels = model.backbone_2d.upsample_channels
        self.fusion = FUSIONS.build(model.fusion, channels)
        self.head = HEADS.build(model.head, config.data, model.backbone_2d, sum(channels))

    def forward(self, batch: PillarBatch) -> HeadOutput:
        return self.head(self.fusion(self.canvas_levels(batch, batch.batch_size * self.canvases), batch.batch_size))

    def canvas_levels(self, batch: PillarBatch, canvases: int) -> list[torch.Tensor]:
        """The backbone's levels (canvases, C_i, H, W) of the batch's pillars, one per canvas: the part of
        the model that sees one canvas alone (train.detector.streaming runs it once per frame)."""
        return self.backbone_2d(self.pillar_encoder(batch.features, batch.pillar, batch.point_pillar, canvases))


def build_detector(config: DetectorConfig) -> Detector:
    torch.manual_seed(config.seed)
    return Detector(config)
