"""The detector a config describes: `single`, `early` or `late` PointPillars."""

from __future__ import annotations

import torch
from torch import nn

from train.config import DetectorConfig
from train.data import POINT_FEATURES, Batch
from train.models.backbone import Backbone
from train.models.fusion import ConcatLevels, LateFusion
from train.models.head import DetectionHead, HeadOutput
from train.models.pillars import PillarFeatureNet


class Detector(nn.Module):
    """Batch -> per-anchor scores, K boxes and direction logits.

    `single` and `early` run the backbone on one pseudo-image per sample (early: the three sweeps
    merged, with a time channel); `late` runs it on each frame's and fuses the levels.
    """

    def __init__(self, config: DetectorConfig) -> None:
        super().__init__()
        model = config.model
        self.canvases = model.canvases
        point_features = POINT_FEATURES + (1 if model.fusion == "early" else 0)
        self.pillars = PillarFeatureNet(config, point_features)
        self.backbone = Backbone(model.backbone, model.pillar_channels)
        channels = model.backbone.upsample_channels
        self.fusion = LateFusion(channels, self.canvases) if model.fusion == "late" else ConcatLevels()
        self.head = DetectionHead(sum(channels), len(model.anchor.yaws_rad), model.tracklet_boxes)

    def forward(self, batch: Batch) -> HeadOutput:
        images = self.pillars(batch.features, batch.pillar, batch.batch_size * self.canvases)
        return self.head(self.fusion(self.backbone(images), batch.batch_size))


def build_detector(config: DetectorConfig) -> Detector:
    torch.manual_seed(config.seed)
    return Detector(config)
