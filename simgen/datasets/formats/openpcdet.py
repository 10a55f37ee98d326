"""The `openpcdet` format: OpenPCDet's custom format, a .npy of points and a label file per frame
(`simgen.datasets.openpcdet`), split by ImageSets; the card gives OpenPCDet's class map and dataset YAML."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from simgen.datasets import mmdet3d, openpcdet, openpcdet_config
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


class OpenPCDet(DatasetFormat):
    name = "openpcdet"
    carries = Carries(track_ids=False, point_fields=False, point_counts=False, units=True)
    max_frames_per_clip = MAX_FRAMES_PER_CLIP
    frame_files = True

    def stream(self, root, clip, clip_index, sensors):
        return openpcdet.OpenPCDetClipStream(root, clip_index, sensors)

    def reader(self, files, manifest):
        return openpcdet.OpenPCDetReader(files, {c.clip: c.clip_index for c in manifest.clips}, manifest.sensors)

    def clip_files(self, entry: ClipEntry) -> set[str]:
        paths = (openpcdet.points_path, openpcdet.labels_path)
        return {f(entry.clip_index, i) for i in range(entry.frames) for f in paths}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        return set(IMAGE_SETS) | {mmdet3d.info_path(split) for split in mmdet3d.SPLITS}

    def finish(self, root: Path, clips: Sequence[ClipRecord], sensors, scenario: Mapping) -> list[FileRecord]:
        return write_image_sets(root, clips) + mmdet3d.write_infos(root, clips)

    def card_layout(self, manifest: Manifest) -> list[str]:
        return [
            "OpenPCDet's custom format (`pcdet/datasets/custom`), no conversion needed:",
            "",
            f"- `points/NNNNNN.npy`: float32 (N, 5) x, y, z (metres, pitch frame), intensity / {INTENSITY_SCALE:g} in",
            "  [0, 1], `lidar_unit`: the head that fired, numbered across the sensors in sensor then head order (the",
            "  manifest's `sensors`; a Mid-100 has three). The dataset YAML lists it in `src_feature_list`, not in",
            "  `used_feature_list`: OpenPCDet reads it and leaves it out of the model's input.",
            "- `labels/NNNNNN.txt`: `x y z dx dy dz heading name`, the box convention below (OpenPCDet's own)",
            "- `ImageSets/train.txt`, `val.txt`, `trainval.txt`: sample numbers, split by clip (a dataset of one clip:",
            f"  its last {VAL_FRACTION:.0%} of frames are `val`, so that OpenPCDet's evaluation has a sample)",
            "",
            f"NNNNNN = clip index x {MAX_FRAMES_PER_CLIP} + frame index. "
            "The `POINT_CLOUD_RANGE` must cover the pitch about",
            "its centre (the points are not centred on the sensor).",
            "",
            "### OpenPCDet",
            "",
            *openpcdet_config.card_lines(),
            "",
            "### MMDetection3D",
            "",
            *mmdet3d.card_lines(),
        ]

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        return lambda k, i: (str(root / openpcdet.labels_path(entry.clip_index, k)), i + 1)  # line number, from 1


FORMAT = OpenPCDet()
