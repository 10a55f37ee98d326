"""How a training step uses a GPU (`train.cudnn_benchmark`, `train.channels_last`, `train.compile`): choices
that change the speed of a step, not what it computes (up to floating-point order).

- cudnn_benchmark: cuDNN times its convolution algorithms for each input shape once and keeps the
  fastest; the backbone's shapes are fixed by the grid, so every step after the first reuses them.
- channels_last: the convolutions' weights and feature maps in (N, H, W, C) memory, the layout the
  GPU's tensor-core convolutions read without a transpose; the sparse canvas is born in it
  (train.detector.sparse_canvas) and the late fusion stacks the frames in it (one copy per level).
- compile: the training step through torch.compile of the whole detector (the module itself stays
  eager: the val pass, BatchNorm folding and checkpoints see the plain model); the dense parts'
  shapes are fixed by the grid, the pillars' vary and are traced once as dynamic.

`auto` turns a choice on for CUDA alone; on the CPU every step is the same as without this module.
"""

from __future__ import annotations

import torch
from torch import nn

from train.config import TrainConfig


def wanted(mode: str, device: torch.device) -> bool:
    """Whether a choice `on` / `off` / `auto` (CUDA alone) is taken on `device`."""
    return mode == "on" or (mode == "auto" and device.type == "cuda")


def accelerate(model: nn.Module, train: TrainConfig, device: torch.device) -> nn.Module:
    """`model` (already on `device`) set up in place for `train`'s speed choices, and what a training step calls.

    Args:
        model: a train.detector.model.Detector.
        train: its config's train section.
        device: where it runs.
    Returns:
        the callable for the training step: `model` itself, or its compiled wrapper (same parameters).
    """
    if device.type == "cuda":
        torch.backends.cudnn.benchmark = wanted(train.cudnn_benchmark, device)
    if wanted(train.channels_last, device):
        for part in model.modules():
            if isinstance(part, (nn.Conv2d, nn.ConvTranspose2d)):  # 4D weights (the fusion's Conv3d is 5D)
                part.to(memory_format=torch.channels_last)
    # emulate_precision_casts: Inductor rounds each bfloat16 intermediate as eager does. Without it the pillar
    # encoder's BatchNorm output, recomputed in the backward, stays float32 and no longer equals the bfloat16
    # maxima the forward kept: scatter_reduce's amax backward finds no point at a maximum, divides by zero, and
    # every gradient is NaN from the first step.
    if wanted(train.compile, device):
        return torch.compile(model, options={"emulate_precision_casts": True})
    return model
