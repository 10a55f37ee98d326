"""The paper's loss (eq. 2): alpha L_cls + sum_i lambda_i L_loc^i + beta L_dir.

L_cls: sigmoid focal loss over positive and negative anchors; L_loc^i: smooth L1 of box i's
residuals at positive anchors, the yaw term as sin(yaw_pred - yaw_true) (SECOND); L_dir: cross
entropy of the direction bin at positive anchors. All are normalised by the number of positives. Nothing here reads a
value back from the device:
a training step runs without host synchronisation (`LossTerms.as_floats` does, every `log_every`).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F

from train.config import LossConfig
from train.detector.head import HeadOutput
from train.detector.target_assigner import BatchTargets


@dataclass(frozen=True)
class LossTerms:
    total: torch.Tensor
    cls: torch.Tensor
    loc: tuple[torch.Tensor, ...]  # per box, oldest first (unweighted)
    direction: torch.Tensor

    def as_floats(self) -> dict[str, float]:
        out = {"loss": self.total.item(), "loss_cls": self.cls.item(), "loss_dir": self.direction.item()}
        out.update({f"loss_loc_{i}": v.item() for i, v in enumerate(self.loc)})
        return out


def focal_loss(logits: torch.Tensor, target: torch.Tensor, alpha: float, gamma: float) -> torch.Tensor:
    """Element-wise sigmoid focal loss (Lin et al.)."""
    prob = torch.sigmoid(logits)
    ce = F.binary_cross_entropy_with_logits(logits, target, reduction="none")
    p_t = prob * target + (1 - prob) * (1 - target)
    alpha_t = alpha * target + (1 - alpha) * (1 - target)
    return alpha_t * (1 - p_t) ** gamma * ce


def _sin_yaw(pred: torch.Tensor, target: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Replace the yaw residuals so that their difference is sin(pred - target)."""
    sin_pred = torch.sin(pred[..., 6:]) * torch.cos(target[..., 6:])
    sin_target = torch.cos(pred[..., 6:]) * torch.sin(target[..., 6:])
    return torch.cat([pred[..., :6], sin_pred], -1), torch.cat([target[..., :6], sin_target], -1)


def detection_loss(output: HeadOutput, targets: BatchTargets, config: LossConfig) -> LossTerms:
    """The loss of a batch's head outputs (float32) against the assigner's targets."""
    labels = targets.labels.reshape(-1)
    positives = max(len(targets.positives), 1)  # a shape, known on the host: no device synchronisation
    scores = output.scores.reshape(-1)
    cared = (labels >= 0).to(scores.dtype)  # weights, not a boolean index (which would synchronise)
    cls = (
        focal_loss(scores, (labels == 1).to(scores.dtype), config.focal_alpha, config.focal_gamma) * cared
    ).sum() / positives

    boxes = output.deltas.shape[2]
    pred = output.deltas.reshape(-1, boxes, 7)[targets.positives]
    pred, target = _sin_yaw(pred, targets.deltas)
    per_box = F.smooth_l1_loss(pred, target, beta=config.smooth_l1_beta, reduction="none").sum(-1)  # (n, K)
    per_box = (per_box * targets.box_mask).sum(0) / positives
    loc = tuple(per_box[k] for k in range(boxes))
    weights = config.loc_weights[-boxes:]

    direction = output.direction.reshape(-1, 2)[targets.positives]
    dir_loss = F.cross_entropy(direction, targets.direction, reduction="sum") / positives

    total = config.cls_weight * cls + sum(w * v for w, v in zip(weights, loc)) + config.dir_weight * dir_loss
    return LossTerms(total, cls, loc, dir_loss)
