"""SECOND's residual box coding against anchors, and the direction bin of a yaw.

Box (x, y, z, length, width, height, yaw) against anchor a: ((x - xa) / d, (y - ya) / d,
(z - za) / ha, log(l / la), log(w / wa), log(h / ha), yaw - yaw_a) with d = sqrt(la^2 + wa^2).
Every box of a tracklet is coded against the anchor of its box at t.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from train.config import BoxCoderConfig
from train.detector.registry import BOX_CODERS


def encode(anchors: NDArray[np.float32], boxes: NDArray[np.float32]) -> NDArray[np.float32]:
    """Residuals (n, K, 7) of boxes (n, K, 7) against anchors (n, 7)."""
    a = anchors[:, None, :]
    diag = np.hypot(a[..., 3], a[..., 4])
    return np.stack(
        [
            (boxes[..., 0] - a[..., 0]) / diag,
            (boxes[..., 1] - a[..., 1]) / diag,
            (boxes[..., 2] - a[..., 2]) / a[..., 5],
            np.log(np.maximum(boxes[..., 3], 1e-3) / a[..., 3]),
            np.log(np.maximum(boxes[..., 4], 1e-3) / a[..., 4]),
            np.log(np.maximum(boxes[..., 5], 1e-3) / a[..., 5]),
            boxes[..., 6] - a[..., 6],
        ],
        axis=-1,
    ).astype(np.float32)


def decode(anchors: torch.Tensor, deltas: torch.Tensor) -> torch.Tensor:
    """Boxes (n, K, 7) from residuals (n, K, 7) and anchors (n, 7); yaw not yet binned."""
    a = anchors[:, None, :]
    diag = torch.hypot(a[..., 3], a[..., 4])
    return torch.stack(
        [
            deltas[..., 0] * diag + a[..., 0],
            deltas[..., 1] * diag + a[..., 1],
            deltas[..., 2] * a[..., 5] + a[..., 2],
            torch.exp(deltas[..., 3].clamp(max=5.0)) * a[..., 3],
            torch.exp(deltas[..., 4].clamp(max=5.0)) * a[..., 4],
            torch.exp(deltas[..., 5].clamp(max=5.0)) * a[..., 5],
            deltas[..., 6] + a[..., 6],
        ],
        dim=-1,
    )


def direction_bin(yaw_rad: NDArray[np.float32], offset_rad: float) -> NDArray[np.int64]:
    """0 or 1: which half-turn, starting at `offset_rad`, the heading lies in."""
    turned = np.mod(yaw_rad - offset_rad, 2 * math.pi)
    return np.clip(np.floor(turned / math.pi), 0, 1).astype(np.int64)


def apply_direction(yaw_rad: torch.Tensor, bins: torch.Tensor, offset_rad: float) -> torch.Tensor:
    """Yaw with its half-turn chosen by the direction classifier: in [offset, offset + 2 pi)."""
    within = torch.remainder(yaw_rad - offset_rad, math.pi)
    return within + offset_rad + math.pi * bins.to(yaw_rad.dtype)


@dataclass(frozen=True)
class BoxCoder:
    """A named coding: residuals from boxes against anchors (numpy, in the loader) and back (torch)."""

    encode: Callable[[NDArray[np.float32], NDArray[np.float32]], NDArray[np.float32]]
    decode: Callable[[torch.Tensor, torch.Tensor], torch.Tensor]


@BOX_CODERS.register("residual")
def residual_coder(section: BoxCoderConfig) -> BoxCoder:
    return BoxCoder(encode, decode)
