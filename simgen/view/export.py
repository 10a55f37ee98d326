"""A frame's points as PCD or PLY (Open3D): x, y, z in the pitch frame (metres) and intensity
(0-255) as a scalar field, for CloudCompare, Open3D's viewer or PCL."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simgen.datasets.frame import Frame
from simgen.errors import UserError
from simgen.view.output import atomic_suffixed

BYTES_PER_POINT = 16  # binary PCD and PLY: x, y, z and intensity as float32


def export_frame(frame: Frame, path: Path) -> None:
    """Write the frame's points to `path` (.pcd or .ply, binary)."""
    import open3d as o3d

    cloud = o3d.t.geometry.PointCloud()
    cloud.point.positions = o3d.core.Tensor(np.ascontiguousarray(frame.points_m, np.float32))
    cloud.point.intensity = o3d.core.Tensor(np.asarray(frame.intensity, np.float32).reshape(-1, 1))
    with atomic_suffixed(path) as tmp:
        if not o3d.t.io.write_point_cloud(str(tmp), cloud):
            raise UserError(f"{path}: Open3D could not write the point cloud")
        # Open3D reports a failed close (a full disk) as success
        if tmp.stat().st_size < BYTES_PER_POINT * len(frame.points_m):
            raise UserError(f"{path}: written incompletely (is the disk full?)")
