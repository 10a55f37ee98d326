"""Anchors on the output grid, SSD style: `len(yaws_rad)` per cell (the paper: two, 0 and 90 degrees).

Anchors are ordered (row along y, column along x, anchor), the order of the head's outputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from train.config import AnchorConfig, DataConfig


@dataclass(frozen=True)
class AnchorGrid:
    anchors: NDArray[np.float32]  # (rows * columns * per_cell, 7) x, y, z, l, w, h, yaw; metres, radians
    shape: tuple[int, int, int]  # rows, columns, anchors per cell
    cell_m: float  # output cell size
    origin_m: tuple[float, float]  # x, y of the grid's corner

    def __len__(self) -> int:
        return len(self.anchors)


def anchor_grid(anchor: AnchorConfig, data: DataConfig, output_stride: int) -> AnchorGrid:
    """The anchors of the output grid: the pillar grid coarsened by `output_stride`."""
    cell_m = data.pillar_size_m * output_stride
    rows, cols = (n // output_stride for n in data.grid_size)
    x0, y0 = data.point_range_m[0], data.point_range_m[1]
    ys = y0 + (np.arange(rows) + 0.5) * cell_m
    xs = x0 + (np.arange(cols) + 0.5) * cell_m
    grid_y, grid_x, yaw = np.meshgrid(ys, xs, anchor.yaws_rad, indexing="ij")
    size = np.broadcast_to(np.asarray(anchor.size_m), grid_x.shape + (3,))
    anchors = np.concatenate(
        [np.stack([grid_x, grid_y, np.full_like(grid_x, anchor.z_m)], -1), size, yaw[..., None]], axis=-1
    ).reshape(-1, 7).astype(np.float32)
    return AnchorGrid(anchors, (rows, cols, len(anchor.yaws_rad)), cell_m, (x0, y0))
