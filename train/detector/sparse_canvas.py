"""The pillar encoder's pseudo-images kept sparse: only the non-empty pillars, and the first conv on them.

A LiDAR this sparse fills a few percent of the pillars: scattering 64 features into a dense
(canvases, 64, rows, columns) image and running a 3 x 3 convolution over it spends most of a
training step writing, copying and differentiating zeros (on paper_x1's compact late model, ~0.6 s
of a ~1 s CPU step). `sparse_conv2d` computes the same convolution from the non-empty pillars alone:
each pillar adds, for each kernel tap, its features times that tap's weights to the output cell the
tap maps it to (a sum over the same terms as the dense convolution, in another order). Only the
output, with the convolution's fewer channels, is dense.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn


@dataclass(frozen=True)
class SparseCanvas:
    """Pseudo-images (canvases, channels, rows, columns) of which only `index`'s cells are non-zero."""

    features: torch.Tensor  # (U, C) the non-empty pillars' features
    index: torch.Tensor  # (U,) int64 flat cell index canvas * rows * columns + row * columns + column
    canvases: int
    rows: int
    cols: int

    def dense(self, memory_format: torch.memory_format = torch.contiguous_format) -> torch.Tensor:
        """(canvases, C, rows, columns): the pillars scattered into zeros, in `memory_format`."""
        cells = self.rows * self.cols
        canvas = self.features.new_zeros(self.canvases * cells, self.features.shape[1])
        canvas = canvas.index_copy(0, self.index, self.features)
        return canvas.view(self.canvases, self.rows, self.cols, -1).permute(0, 3, 1, 2).contiguous(
            memory_format=memory_format)


def sparse_conv2d(canvas: SparseCanvas, conv: nn.Conv2d) -> torch.Tensor:
    """`conv(canvas.dense())` (any kernel, stride, zero padding; no groups or dilation) from the pillars alone,
    channels-last where the convolution's weights are (train.accelerate)."""
    if conv.groups != 1 or conv.dilation != (1, 1) or conv.padding_mode != "zeros" or isinstance(conv.padding, str):
        raise ValueError("sparse_conv2d takes plain zero-padded convolutions")
    (kernel_r, kernel_c), (stride_r, stride_c), (pad_r, pad_c) = conv.kernel_size, conv.stride, conv.padding
    out_rows = (canvas.rows + 2 * pad_r - kernel_r) // stride_r + 1
    out_cols = (canvas.cols + 2 * pad_c - kernel_c) // stride_c + 1
    cells = canvas.rows * canvas.cols
    image, within = canvas.index // cells, canvas.index % cells
    row, col = within // canvas.cols, within % canvas.cols
    # every tap at once: tap t = (t // kernel_c, t % kernel_c) of each pillar, (U, taps)
    tap = torch.arange(kernel_r * kernel_c, device=row.device)
    shifted_r = row[:, None] + pad_r - tap // kernel_c  # the output row times the stride this tap reaches
    shifted_c = col[:, None] + pad_c - tap % kernel_c
    out_r, out_c = shifted_r.div(stride_r, rounding_mode="floor"), shifted_c.div(stride_c, rounding_mode="floor")
    valid = ((shifted_r % stride_r == 0) & (shifted_c % stride_c == 0) & (out_r >= 0) & (out_r < out_rows)
             & (out_c >= 0) & (out_c < out_cols))
    target = torch.where(valid, (image[:, None] * out_rows + out_r) * out_cols + out_c, 0)
    out = canvas.features.new_zeros(canvas.canvases * out_rows * out_cols, conv.out_channels)
    # every tap's weights in one product: (U, taps, out_channels)
    taps = F.linear(canvas.features, conv.weight.permute(2, 3, 0, 1).reshape(-1, conv.in_channels))
    taps = taps.view(len(canvas.index), kernel_r * kernel_c, conv.out_channels).to(out.dtype) * valid[..., None]
    out = out.index_add(0, target.flatten(), taps.flatten(0, 1))
    out = out.view(canvas.canvases, out_rows, out_cols, conv.out_channels).permute(0, 3, 1, 2)
    if conv.bias is not None:
        out = out + conv.bias[:, None, None]
    return out.contiguous(memory_format=weight_memory_format(conv))


def weight_memory_format(conv: nn.Module) -> torch.memory_format:
    """The memory format a convolution's 4D weights are in: channels-last or the default."""
    weight = conv.weight
    if weight.dim() == 4 and not weight.is_contiguous() and weight.is_contiguous(memory_format=torch.channels_last):
        return torch.channels_last
    return torch.contiguous_format
