"""The `kitti_tracking` format: KITTI tracking's layout, a folder of .bin files and one label file per
clip with frame and track id first, and the boxes with a discontinuity listed in `training/placements/`."""

from __future__ import annotations

from pathlib import Path

from simgen.datasets.formats.base import Carries, Locate
from simgen.datasets.formats.kitti import Kitti, label_path, placements_path
from simgen.datasets.manifest import ClipEntry, Manifest


class KittiTracking(Kitti):
    name = "kitti_tracking"
    carries = Carries(track_ids=True, point_fields=False, point_counts=False)
    frame_files = False  # a clip's one label file grows frame by frame
    tracking = True

    def clip_files(self, entry: ClipEntry) -> set[str]:
        return super().clip_files(entry) | {placements_path(entry.clip_index)}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        return set()

    def finish(self, root, clips, sensors, scenario):
        return []

    def _files(self, images: bool) -> list[str]:
        return [
            "- `training/velodyne/SSSS/NNNNNN.bin`: SSSS the clip index, NNNNNN the frame index in the clip",
            "- `training/label_02/SSSS.txt`: `frame track_id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry`",
            "- `training/calib/SSSS.txt`: KITTI tracking calib (`P0:`-`P3:`, `R_rect`, `Tr_velo_cam`, `Tr_imu_velo`)",
            "- `training/placements/SSSS.txt`: `frame track_id` of each box with a discontinuity "
            "(Restarts, below); KITTI's",
            "  tracking tools ignore the folder",
        ]

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        labels = str(root / label_path(True, entry.clip_index))
        return lambda k, i: (labels, first_row[k] + i + 1)  # line number, from 1


FORMAT = KittiTracking()
