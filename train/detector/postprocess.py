"""Head outputs -> tracklets: score threshold, decoding, the direction bin, NMS on the boxes at t."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from train.config import DetectorConfig
from train.detector.box_coder import apply_direction, decode
from train.detector.head import HeadOutput
from train.detector.nms import nms_bev


@dataclass(frozen=True)
class Detections:
    """One frame's tracklets: K boxes each (oldest first, t last) and a score in [0, 1]."""

    boxes: NDArray[np.float32]  # (N, K, 7)
    scores: NDArray[np.float32]  # (N,)


def postprocess(output: HeadOutput, anchors: torch.Tensor, config: DetectorConfig) -> list[Detections]:
    """Per sample of the batch, the tracklets kept after NMS on their box at t."""
    results = []
    for b in range(output.scores.shape[0]):
        keep, scores = candidates(output.scores[b], config)
        results.append(tracklets(keep, scores, output.deltas[b, keep], output.direction[b, keep], anchors, config))
    return results


def candidates(logits: torch.Tensor, config: DetectorConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """One sample's anchors (K,) scoring at least the threshold, best `pre_nms` first, and all (N_a,) scores."""
    scores = torch.sigmoid(logits)
    keep = torch.nonzero(scores >= config.infer.score_threshold).squeeze(1)
    return keep[torch.argsort(scores[keep], descending=True)[: config.infer.pre_nms]], scores


def tracklets(
    keep: torch.Tensor,
    scores: torch.Tensor,
    deltas: torch.Tensor,
    direction: torch.Tensor,
    anchors: torch.Tensor,
    config: DetectorConfig,
) -> Detections:
    """The `keep` anchors' tracklets (their deltas (K, K_boxes, 7) and direction logits (K, 2)) after NMS."""
    boxes = decode(anchors[keep], deltas)
    bins = direction.argmax(dim=-1)
    boxes[..., 6] = apply_direction(boxes[..., 6], bins[:, None], config.model.head.dir_offset_rad)
    boxes_np = boxes.detach().cpu().numpy().astype(np.float32)
    scores_np = scores[keep].detach().cpu().numpy().astype(np.float32)
    kept = nms_bev(boxes_np[:, -1], scores_np, config.infer.nms_iou, config.infer.max_detections)
    return Detections(boxes_np[kept].reshape(-1, boxes_np.shape[1], 7), scores_np[kept])
