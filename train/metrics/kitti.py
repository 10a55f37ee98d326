"""Tracks and ground truth as KITTI tracking label files, for outside evaluators.

One line per object and frame (frames numbered from 0 in clip order):
``frame track_id type truncated occluded alpha x1 y1 x2 y2 height width length x y z rotation_y [score]``.

3D: KITTI's camera frame is taken from the pitch frame with KITTI's LiDAR-to-camera axes and no
calibration: x_cam = -y, y_cam = -z, z_cam = x; the location is the box's bottom centre and
rotation_y = -yaw - pi/2. 3D IoU is unchanged by this rigid map, so 3D scores (AB3DMOT's
evaluate_kitti3dmot.py with 3D IoU) match those of train.metrics.tracking.

2D: there is no camera, so the image boxes are placeholders: the axis-aligned extent of the box's
footprint in a virtual top-down image at ``px_per_m`` (100) pixels a metre, the pitch's
[-60, 60] x [-40, 40] m onto [0, 12000] x [0, 8000] px (image y pointing to pitch -y), grown about
their centre to at least ``min_px`` (40) pixels on each side, so that the KITTI devkit's 25-pixel
minimum height never drops a box. 2D scores of these boxes are BEV axis-aligned overlaps, not
image overlaps: use the 3D scores.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from train.geometry import bev_corners
from train.tracking.types import GroundTruthFrame, TrackedFrame

_IMAGE_ORIGIN_M = (-60.0, 40.0)  # pitch point at pixel (0, 0)


def _wrap(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    return (angle + np.pi) % (2 * np.pi) - np.pi


def camera_boxes(boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 7) KITTI camera boxes ``(height, width, length, x, y, z, rotation_y)`` of pitch boxes (N, 7)."""
    x, y, z, length, width, height, yaw = boxes.T
    return np.column_stack([height, width, length, -y, -(z - 0.5 * height) + 0.0, x, _wrap(-yaw - 0.5 * np.pi)])


def placeholder_2d(boxes: NDArray[np.float64], px_per_m: float = 100.0, min_px: float = 40.0) -> NDArray[np.float64]:
    """(N, 4) ``x1, y1, x2, y2`` image boxes of pitch boxes (N, 7): see the module docstring."""
    corners = bev_corners(boxes)  # (N, 4, 2)
    u = (corners[..., 0] - _IMAGE_ORIGIN_M[0]) * px_per_m
    v = (_IMAGE_ORIGIN_M[1] - corners[..., 1]) * px_per_m
    low, high = np.stack([u.min(1), v.min(1)], axis=1), np.stack([u.max(1), v.max(1)], axis=1)
    grow = np.maximum(min_px - (high - low), 0.0) / 2
    return np.concatenate([low - grow, high + grow], axis=1)


def kitti_lines(
    frames: Sequence[TrackedFrame] | Sequence[GroundTruthFrame], object_type: str = "Pedestrian"
) -> list[str]:
    """The label lines of a clip; tracker frames add the score column."""
    lines = []
    for index, frame in enumerate(frames):
        camera, image = camera_boxes(frame.boxes), placeholder_2d(frame.boxes)
        alpha = _wrap(camera[:, 6] - np.arctan2(camera[:, 3], camera[:, 5]))
        scores = getattr(frame, "scores", None)
        for i, track_id in enumerate(frame.ids.tolist()):
            fields = [f"{index} {track_id} {object_type} 0 0 {alpha[i]:.6f}"]
            fields += [" ".join(f"{v:.2f}" for v in image[i]), " ".join(f"{v:.6f}" for v in camera[i])]
            if scores is not None:
                fields.append(f"{scores[i]:.6f}")
            lines.append(" ".join(fields))
    return lines


def write_kitti_tracking(
    path: str | Path, frames: Sequence[TrackedFrame] | Sequence[GroundTruthFrame], object_type: str = "Pedestrian"
) -> None:
    """Write one clip (one KITTI sequence) to path."""
    Path(path).write_text("".join(line + "\n" for line in kitti_lines(frames, object_type)))
