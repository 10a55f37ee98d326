"""BatchNorm folded into the convolution or Linear before it, for inference.

In eval mode a BatchNorm is a per-channel scale and shift: folded into the weights and bias of the
layer that feeds it, it costs nothing (on CPU, the detector's BatchNorms take about a fifth of its
inference time). The outputs equal the unfolded model's up to float32 rounding.
"""

from __future__ import annotations

import copy

from torch import nn
from torch.nn.utils.fusion import fuse_conv_bn_eval, fuse_linear_bn_eval

from train.detector.model import Detector

_CONVS = (nn.Conv2d, nn.Conv3d, nn.ConvTranspose2d)
_NORMS = (nn.BatchNorm1d, nn.BatchNorm2d, nn.BatchNorm3d)


def fold_batchnorm(model: Detector) -> Detector:
    """An eval-mode copy of `model` with each BatchNorm that follows a convolution in a Sequential, and the
    pillar encoder's, folded into that layer (the BatchNorm becomes an identity)."""
    folded = copy.deepcopy(model).eval()
    for sequence in [m for m in folded.modules() if isinstance(m, nn.Sequential)]:
        for i in range(1, len(sequence)):
            if isinstance(sequence[i], _NORMS) and isinstance(sequence[i - 1], _CONVS):
                conv = sequence[i - 1]
                sequence[i - 1] = fuse_conv_bn_eval(conv, sequence[i], transpose=isinstance(conv, nn.ConvTranspose2d))
                sequence[i] = nn.Identity()
    encoder = folded.pillar_encoder
    encoder.linear, encoder.norm = fuse_linear_bn_eval(encoder.linear, encoder.norm), nn.Identity()
    return folded
