"""The virtual camera that gives KITTI labels their camera coordinates, 2D boxes and calib files.

A stationary LiDAR over a pitch has no camera, but KITTI labels are written in one. The points
stay in the pitch frame (the "velodyne" frame of the files is the pitch frame, not the sensor's),
and a virtual pinhole camera stands behind the left goal, at pitch (-CAMERA_DISTANCE_M, 0, 0),
looking along +x with KITTI's axes:

    x_cam = -y,  y_cam = -z,  z_cam = x + CAMERA_DISTANCE_M      (Tr_velo_to_cam; R0_rect = I)
    ry = -yaw - pi/2 (wrapped to (-pi, pi]);  location = the box's bottom centre

It stands near the pitch so that camera coordinates stay at KITTI's own scale: everything up to
MAX_X_M from the centre spot (behind the nets) is 94-206 m in front of it, where float32 tools
(OpenPCDet's rotated-IoU kernels compute corners and areas in float32) err by about 0.01 % of a
footprint's area; at 1000 m they err ten times more and lost about 2 points of 3D AP. Nearer
still, the nominal image (which OpenPCDet reads for its shape and field-of-view filter) would grow
past 100 megapixels. FOCAL_PX makes a box MIN_BOX_HEIGHT_M tall stand MIN_BOX_PX high even at the
farthest depth, where KITTI's evaluators drop boxes under 25 px; 2D boxes are the 8 corners
projected with P2, not clipped. The nominal image holds |y| <= MAX_Y_M and Z_RANGE_M from the
nearest depth on (21040 x 1315 px, about 25 degrees wide). From float32 boxes every conversion is
exact in float64 but the yaw's.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.samples import float64_text

CAMERA_DISTANCE_M = 150.0
MAX_X_M = 56.0  # beyond the goal lines, behind the nets
MAX_Y_M = 40.0  # beyond the touchlines, where the linesmen run
Z_RANGE_M = (-1.0, 4.0)
MIN_BOX_PX = 30.0  # KITTI's evaluators keep boxes of 25 px and more (moderate, hard)
MIN_BOX_HEIGHT_M = 0.25  # a humanoid lying on the ground is taller
NEAR_DEPTH_M = CAMERA_DISTANCE_M - MAX_X_M
FOCAL_PX = float(math.ceil(MIN_BOX_PX * (CAMERA_DISTANCE_M + MAX_X_M) / MIN_BOX_HEIGHT_M))
PRINCIPAL_PX = (
    float(math.ceil(FOCAL_PX * MAX_Y_M / NEAR_DEPTH_M)),
    float(math.ceil(FOCAL_PX * Z_RANGE_M[1] / NEAR_DEPTH_M)),
)
IMAGE_SIZE_PX = (int(2 * PRINCIPAL_PX[0]), math.ceil(FOCAL_PX * (Z_RANGE_M[1] - Z_RANGE_M[0]) / NEAR_DEPTH_M))

VELO_TO_CAM = np.array([[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [1.0, 0.0, 0.0, CAMERA_DISTANCE_M]])
PROJECTION = np.array(
    [[FOCAL_PX, 0.0, PRINCIPAL_PX[0], 0.0], [0.0, FOCAL_PX, PRINCIPAL_PX[1], 0.0], [0.0, 0.0, 1.0, 0.0]]
)
IDENTITY_3X4 = np.eye(3, 4)


def wrap(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles in (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def to_camera(points_m: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3) pitch frame -> (N, 3) camera coordinates, metres."""
    return points_m @ VELO_TO_CAM[:, :3].T + VELO_TO_CAM[:, 3]


def from_camera(points_cam: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverse of `to_camera` (exact: the rotation has entries 0 and +-1)."""
    return (points_cam - VELO_TO_CAM[:, 3]) @ VELO_TO_CAM[:, :3]


def corners(boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """(H, 8, 3) corners of pitch-frame boxes (H, 7)."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], np.float64)
    local = 0.5 * signs[None] * boxes[:, None, 3:6]
    cos, sin = np.cos(boxes[:, 6])[:, None], np.sin(boxes[:, 6])[:, None]
    x = cos * local[..., 0] - sin * local[..., 1]
    y = sin * local[..., 0] + cos * local[..., 1]
    return np.stack([x, y, local[..., 2]], axis=-1) + boxes[:, None, :3]


def image_boxes(boxes: NDArray[np.float64]) -> NDArray[np.float64]:
    """(H, 4) x1, y1, x2, y2 pixels: the projected corners' bounds (not clipped to the image)."""
    cam = to_camera(corners(boxes).reshape(-1, 3))
    u = PROJECTION[0, 0] * cam[:, 0] / cam[:, 2] + PROJECTION[0, 2]
    v = PROJECTION[1, 1] * cam[:, 1] / cam[:, 2] + PROJECTION[1, 2]
    u, v = u.reshape(-1, 8), v.reshape(-1, 8)
    return np.stack([u.min(1), v.min(1), u.max(1), v.max(1)], axis=1)


def kitti_boxes(boxes: NDArray[np.float32]) -> dict[str, NDArray[np.float64]]:
    """KITTI fields of pitch-frame boxes (H, 7): dims (h, w, l), location (bottom centre), ry, alpha, bbox."""
    b = np.asarray(boxes, np.float64).reshape(-1, 7)
    bottom = b[:, :3] - np.stack([np.zeros(len(b)), np.zeros(len(b)), b[:, 5] / 2], axis=1)
    location = to_camera(bottom)
    ry = wrap(-b[:, 6] - np.pi / 2)
    return {
        "dims": b[:, [5, 4, 3]],
        "location": location,
        "ry": ry,
        "alpha": wrap(ry - np.arctan2(location[:, 0], location[:, 2])),
        "bbox": image_boxes(b),
    }


def pitch_boxes(
    dims: NDArray[np.float64], location: NDArray[np.float64], ry: NDArray[np.float64]
) -> NDArray[np.float32]:
    """Inverse of `kitti_boxes`: (H, 7) float32 pitch-frame boxes from KITTI dims (h, w, l), location, ry."""
    h, w, length = dims[:, 0], dims[:, 1], dims[:, 2]
    bottom = from_camera(location)
    centre = bottom + np.stack([np.zeros(len(h)), np.zeros(len(h)), h / 2], axis=1)
    yaw = wrap(-ry - np.pi / 2)
    return np.column_stack([centre, length, w, h, yaw]).astype(np.float32).reshape(-1, 7)


def _matrix_text(matrix: NDArray[np.float64]) -> str:
    return " ".join(float64_text(v) for v in matrix.reshape(-1))


def calib_lines(tracking: bool) -> list[str]:
    """A calib file: the object layout's `key: values` lines, or the tracking layout's names."""
    names = ("R_rect", "Tr_velo_cam", "Tr_imu_velo") if tracking else ("R0_rect:", "Tr_velo_to_cam:", "Tr_imu_to_velo:")
    matrices = (np.eye(3), VELO_TO_CAM, IDENTITY_3X4)
    cameras = [f"P{i}: {_matrix_text(PROJECTION)}" for i in range(4)]
    return cameras + [f"{name} {_matrix_text(matrix)}" for name, matrix in zip(names, matrices)]
