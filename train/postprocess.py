"""Head outputs -> tracklets: score threshold, decoding, the direction bin, NMS on the boxes at t."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from train.config import DetectorConfig
from train.models.box_coder import apply_direction, decode
from train.models.head import HeadOutput
from train.nms import nms_bev


@dataclass(frozen=True)
class Detections:
    """One frame's tracklets: K boxes each (oldest first, t last) and a score in [0, 1]."""

    boxes: NDArray[np.float32]  # (N, K, 7)
    scores: NDArray[np.float32]  # (N,)


def postprocess(output: HeadOutput, anchors: torch.Tensor, config: DetectorConfig) -> list[Detections]:
    """Per sample of the batch, the tracklets kept after NMS on their box at t."""
    infer = config.infer
    results = []
    for b in range(output.scores.shape[0]):
        scores = torch.sigmoid(output.scores[b])
        keep = torch.nonzero(scores >= infer.score_threshold).squeeze(1)
        keep = keep[torch.argsort(scores[keep], descending=True)[: infer.pre_nms]]
        boxes = decode(anchors[keep], output.deltas[b, keep])
        bins = output.direction[b, keep].argmax(dim=-1)
        boxes[..., 6] = apply_direction(boxes[..., 6], bins[:, None], config.model.head.dir_offset_rad)
        boxes_np = boxes.detach().cpu().numpy().astype(np.float32)
        scores_np = scores[keep].detach().cpu().numpy().astype(np.float32)
        kept = nms_bev(boxes_np[:, -1], scores_np, infer.nms_iou, infer.max_detections)
        results.append(Detections(boxes_np[kept].reshape(-1, boxes_np.shape[1], 7), scores_np[kept]))
    return results
