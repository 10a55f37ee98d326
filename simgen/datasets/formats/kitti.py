"""The `kitti` format (KITTI object detection: a file per frame, split by ImageSets; optional placeholder
images) and what `kitti_tracking` (kitti_tracking.py) shares with it; files in `simgen.datasets.kitti`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from simgen.datasets import kitti
from simgen.datasets import kitti_camera as camera
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import ClipRecord, FileRecord
from simgen.datasets.samples import (
    IMAGE_SETS,
    INTENSITY_SCALE,
    MAX_FRAMES_PER_CLIP,
    VAL_FRACTION,
    write_image_sets,
)


def _with_images(scenario: Mapping) -> bool:
    """Whether the scenario asked for placeholder images (`dataset.kitti_images`)."""
    return bool(scenario.get("dataset", {}).get("kitti_images"))


class Kitti(DatasetFormat):
    name = "kitti"
    carries = Carries(track_ids=False, point_fields=False, point_counts=False)
    max_frames_per_clip = MAX_FRAMES_PER_CLIP
    placeholder_images = True
    frame_files = True
    tracking = False  # KITTI tracking's layout (kitti_tracking.py)

    def stream(self, root, clip, clip_index, sensors):
        return kitti.KittiClipStream(root, clip_index, tracking=self.tracking)

    def reader(self, files, manifest):
        clips = manifest.clips
        return kitti.KittiReader(files, {c.clip: c.clip_index for c in clips}, self.tracking,
                                 {c.clip_index: c.frames for c in clips})

    def clip_files(self, entry: ClipEntry) -> set[str]:
        paths = (kitti.velodyne_path, kitti.label_path, kitti.calib_path)
        return {f(self.tracking, entry.clip_index, i) for i in range(entry.frames) for f in paths}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        images = {kitti.image_path(c.clip_index, i) for c in manifest.clips for i in range(c.frames)}
        return set(IMAGE_SETS) | (images if _with_images(manifest.scenario) else set())

    def finish(self, root: Path, clips: Sequence[ClipRecord], sensors, scenario: Mapping) -> list[FileRecord]:
        files = write_image_sets(root, clips)
        if _with_images(scenario):
            files += kitti.write_placeholder_images(root, [(c.clip_index, c.frames) for c in clips])
        return files

    def card_layout(self, manifest: Manifest) -> list[str]:
        return self._files(_with_images(manifest.scenario)) + _common_layout()

    def _files(self, images: bool) -> list[str]:
        files = [
            f"- `training/velodyne/NNNNNN.bin`: NNNNNN = clip index x {MAX_FRAMES_PER_CLIP} + frame index",
            "- `training/label_2/NNNNNN.txt`: `type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry`",
            "- `training/calib/NNNNNN.txt`: KITTI object calib "
            "(`P0:`-`P3:`, `R0_rect:`, `Tr_velo_to_cam:`, `Tr_imu_to_velo:`)",
            "- `ImageSets/train.txt`, `val.txt`, `trainval.txt`: sample numbers, split by clip (a dataset of one clip:",
            f"  its last {VAL_FRACTION:.0%} of frames are `val`, so that OpenPCDet's evaluation has a sample)",
        ]
        if images:
            files.append(
                "- `training/image_2/NNNNNN.png`: blank placeholders of the virtual camera's nominal size (1-bit PNG),"
                " for tools that open every image (OpenPCDet's KITTI info generation)"
            )
        return files

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        return lambda k, i: (str(root / kitti.label_path(False, entry.clip_index, k)), i + 1)  # line number, from 1


def _common_layout() -> list[str]:
    """The card's lines on the .bin files and the virtual camera, for both KITTI layouts."""
    min_height_m = camera.MIN_BOX_PX * (camera.CAMERA_DISTANCE_M + camera.MAX_X_M) / camera.FOCAL_PX
    return [
        "",
        f"`.bin`: float32 x, y, z (metres, **pitch frame**, not the sensor's), intensity / {INTENSITY_SCALE:g} "
        "in [0, 1].",
        "The \"velodyne\" frame of these files is the pitch frame: KITTI tools that assume a sensor at the origin",
        "looking along +x (range crops, field-of-view filters) need the pitch's range instead.",
        "",
        "Labels are in a **virtual camera** (a stationary LiDAR over a pitch has none), stated exactly in `calib/`:",
        f"a pinhole at pitch (-{camera.CAMERA_DISTANCE_M:g}, 0, 0) m looking along +x with KITTI's camera axes,",
        f"`x_cam = -y`, `y_cam = -z`, `z_cam = x + {camera.CAMERA_DISTANCE_M:g}` "
        "(`Tr_velo_to_cam`; `R0_rect` = identity;",
        f"`Tr_imu_to_velo` = identity, there is no IMU), focal length {camera.FOCAL_PX:g} px, principal point",
        f"{camera.PRINCIPAL_PX} px, nominal image {camera.IMAGE_SIZE_PX[0]} x {camera.IMAGE_SIZE_PX[1]} px "
        "(image files only as placeholders).",
        "`location` is the box's bottom centre in that camera, `h w l` its height, width (across the heading) and",
        "length (along it), `ry = -yaw - pi/2`; `alpha = ry - atan2(x_cam, z_cam)`. The 2D box is the projection of",
        "the 8 corners with P2 (not clipped): a box",
        f"{min_height_m:.2f} m tall or more is at least {camera.MIN_BOX_PX:g} px tall "
        f"anywhere up to x = {camera.MAX_X_M:g} m,",
        "so KITTI's evaluators (which drop boxes under 25-40 px) keep every humanoid.",
        "`truncated` is 0; `occluded` is 0, or 3 (unknown) for a humanoid with no point on it in that frame.",
    ]


FORMAT = Kitti()
