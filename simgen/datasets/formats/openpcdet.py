"""The `openpcdet` format: its writer, reader and plug-in. OpenPCDet's custom format, `points/NNNNNN.npy`,
`labels/NNNNNN.txt`, split by `ImageSets/{train,val}.txt`, with MMDetection3D's info files beside them; the card
gives OpenPCDet's class map and dataset YAML (`simgen.datasets.openpcdet_config`).

Points: .npy float32 (P, 5) x, y, z, intensity / 255, in the pitch frame as is (so OpenPCDet's
`POINT_CLOUD_RANGE` must cover the pitch, 105 x 68 m about the origin, not a range ahead of a
sensor), and the lidar unit (the head that fired, numbered across the sensors: `simgen.datasets.units`), which
OpenPCDet's custom dataset carries as a source feature its model does not use. Datasets written before the
unit column (P, 4) read too. Labels: one line
per humanoid, `x y z dx dy dz heading name`: centre, length (along the heading), width, height,
yaw counter-clockwise from +x (OpenPCDet's own box convention, which is ours), name `Pedestrian`
or `Official`. NNNNNN is the global sample number of simgen.datasets.samples.

MMDetection3D's info files for an OpenPCDet dataset: `mmdet3d_infos_{train,val}.json`, its v2 info layout
(what `update_infos_to_v2` writes and its current `Det3DDataset` loads), beside the points they name.

JSON, not the .pkl its converters write: `mmengine.load`, which `Det3DDataset` reads its `ann_file` with, takes
either by the file's extension, and a simgen dataset holds no pickle (loading one can run code).

    {"metainfo": {"categories": {"Pedestrian": 0, "Official": 1}, "dataset": "simgen", "info_version": "1.1"},
     "data_list": [{"sample_idx": 10003,
                    "lidar_points": {"num_pts_feats": 5, "lidar_path": "010003.npy"},
                    "instances": [{"bbox_3d": [x, y, z, dx, dy, dz, yaw], "bbox_label_3d": 0}, ...]}, ...]}

`lidar_path` is relative to `data_prefix=dict(pts="points")` (`POINTS_DIR`); the points are
OpenPCDet's (N, 5) .npy (`LoadPointsFromFile(coord_type="LIDAR", load_dim=5, use_dim=4)`); `bbox_3d` is
MMDetection3D's LiDAR box: the centre of the box's bottom face (z = the box centre's - height / 2), length along
the heading, width, height, yaw counter-clockwise from +x, in the pitch frame.
"""

from __future__ import annotations

import io
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simgen.datasets import openpcdet_config
from simgen.datasets.formats import MAX_FRAMES_PER_CLIP
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.frame import Frame, class_names
from simgen.datasets.limits import check_label_lines
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import ClipRecord, FileRecord, write_bytes, write_text
from simgen.datasets.samples import (
    IMAGE_SETS,
    INTENSITY_SCALE,
    VAL_FRACTION,
    float32_text,
    from_xyzi,
    sample_name,
    split_samples,
    to_xyzi,
    write_image_sets,
)
from simgen.datasets.units import unit_numbers, unit_sensor_head
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError
from simgen.vocab import CLASS_NAMES

if TYPE_CHECKING:
    from simgen.datasets.records import ClipRecord
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor


COLUMNS = ("x", "y", "z", "intensity", "lidar_unit")  # of a points file; (P, 4) before the unit column


POINTS_DIR = "points"


def points_file(sample: str) -> str:
    """A sample's points file in POINTS_DIR."""
    return f"{sample}.npy"


def points_path(clip_index: int, index: int) -> str:
    return f"{POINTS_DIR}/{points_file(sample_name(clip_index, index))}"


def sample_labels_path(sample: str) -> str:
    return f"labels/{sample}.txt"


def labels_path(clip_index: int, index: int) -> str:
    return sample_labels_path(sample_name(clip_index, index))


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def label_lines(frame: LabelledFrame) -> list[str]:
    boxes = np.asarray(frame.labels.boxes, np.float32).reshape(-1, 7)
    names = class_names(frame.labels.team)
    return [" ".join([*(float32_text(v) for v in box), name]) for box, name in zip(boxes, names)]


class OpenPCDetClipStream:
    """One clip's OpenPCDet files written as its frames come: per frame its points and labels."""

    def __init__(self, root: Path, clip_index: int, sensors: Sequence[Sensor]):
        self.root, self.clip_index, self.sensors = Path(root), clip_index, sensors
        self.records: list[FileRecord] = []

    def add(self, frame: LabelledFrame) -> None:
        scan = frame.scan
        units = unit_numbers(scan.sensor, scan.head, self.sensors).astype(np.float32)[:, None]
        points = np.ascontiguousarray(np.concatenate([to_xyzi(scan.points_m, scan.intensity), units], axis=1))
        self.records.append(write_bytes(self.root, points_path(self.clip_index, frame.index), npy_bytes(points),
                                        len(points)))
        self.records.append(write_text(self.root, labels_path(self.clip_index, frame.index), label_lines(frame)))

    def close(self) -> list[FileRecord]:
        return self.records

    def abort(self) -> None:
        """Nothing to undo: every file is whole under its final name or absent."""


def parse_labels(text: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(H, 7) float32 boxes and (H,) class names."""
    rows = [line.split() for line in text.splitlines() if line.strip()]
    for number, row in enumerate(rows, 1):
        if len(row) != 8 or row[7] not in CLASS_NAMES:
            raise UserError(f"{path}: line {number} is not `x y z dx dy dz heading name` with a simgen class")
    try:
        boxes = np.array([row[:7] for row in rows], np.float32).reshape(-1, 7)
    except ValueError:
        raise UserError(f"{path}: a label has a field that is not a number") from None
    return boxes, np.array([row[7] for row in rows], np.str_)


def read_points(data: bytes, path: Path, rows: int) -> np.ndarray:
    """(rows, 5) float32 (COLUMNS), or (rows, 4) from a dataset written before the unit column."""
    try:
        points = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise UserError(f"{path}: not a readable .npy file ({error})") from None
    if points.dtype != np.float32 or points.shape not in ((rows, len(COLUMNS)), (rows, 4)):
        raise UserError(f"{path}: {points.dtype} {points.shape}, expected float32 ({rows}, {len(COLUMNS)})")
    return points


class OpenPCDetReader:
    """Frames of an `openpcdet` dataset."""

    def __init__(self, files: DatasetFiles, clip_indices: dict[str, int], sensors: Sequence[Sensor]):
        self.files = files
        self.clip_indices = clip_indices
        self.sensors = sensors

    def frame(self, clip: str, index: int) -> Frame:
        clip_index = self.clip_indices[clip]
        points = points_path(clip_index, index)
        labels = labels_path(clip_index, index)
        array = read_points(self.files.read(points), self.files.root / points, self.files.rows(points))
        xyz, intensity = from_xyzi(array[:, :4])
        sensor = head = None
        if array.shape[1] == len(COLUMNS):
            try:
                sensor, head = unit_sensor_head(array[:, 4], self.sensors)
            except ValueError as error:
                raise UserError(f"{self.files.root / points}: {error}") from None
        text = self.files.read(labels).decode(errors="replace")
        check_label_lines(self.files.root / labels, text, 1)
        boxes, names = parse_labels(text, self.files.root / labels)
        return Frame(clip=clip, index=index, points_m=xyz, intensity=intensity, boxes=boxes, class_name=names,
                     sensor=sensor, head=head)


INFO_VERSION = "1.1"
MMDET3D_SPLITS = ("train", "val")


def mmdet3d_info_path(split: str) -> str:
    return f"mmdet3d_infos_{split}.json"


def bbox_3d(box: np.ndarray) -> list[float]:
    """MMDetection3D's LiDAR box of one simgen box (7,): its bottom face's centre, sizes and yaw."""
    x, y, z, length, width, height, yaw = (float(v) for v in np.asarray(box, np.float32))
    return [x, y, float(np.float32(z - height / 2)), length, width, height, yaw]


def data_info(name: str, boxes: np.ndarray, names: Sequence[str]) -> dict:
    """One sample's info: its points file and its boxes (H, 7) with their class names."""
    labels = {c: i for i, c in enumerate(CLASS_NAMES)}
    return {
        "sample_idx": int(name),
        "lidar_points": {"num_pts_feats": len(COLUMNS), "lidar_path": points_file(name)},
        "instances": [{"bbox_3d": bbox_3d(box), "bbox_label_3d": labels[str(c)]} for box, c in zip(boxes, names)],
    }


def mmdet3d_card_lines() -> list[str]:
    """The dataset card's MMDetection3D section."""
    classes = tuple(CLASS_NAMES)
    return [
        f"`{mmdet3d_info_path('train')}` and `{mmdet3d_info_path('val')}`: MMDetection3D's info files "
        "(its v2 layout, which",
        "`Det3DDataset` loads), the ImageSets' splits: per sample `sample_idx`, `lidar_points` (`lidar_path` under",
        f"`points/`, `num_pts_feats` {len(COLUMNS)}) and `instances` (`bbox_3d`: the LiDAR box, bottom-face",
        "centre x y z, length, width, height, yaw; `bbox_label_3d`: the index in `metainfo.categories`). JSON, which",
        "`mmengine.load` reads as it reads its .pkl infos. In MMDetection3D, a `Det3DDataset` subclass with",
        f"`METAINFO = {{'classes': {classes}}}` whose `parse_ann_info` wraps `gt_bboxes_3d` in `LiDARInstance3DBoxes`",
        "(and gives empty arrays for a sample with no box), `data_prefix=dict(pts='points')` and",
        f"`LoadPointsFromFile(coord_type='LIDAR', load_dim={len(COLUMNS)}, use_dim=4)` reads them.",
    ]


def write_mmdet3d_infos(root: Path, clips: Sequence[ClipRecord]) -> list[FileRecord]:
    """Write the info file of each split from the labels the clips wrote under `root`; rows = samples."""
    records = []
    for split, names in split_samples(clips).items():
        data_list = []
        for name in names:
            labels = root / sample_labels_path(name)
            boxes, classes = parse_labels(labels.read_text(), labels)
            data_list.append(data_info(name, boxes, classes))
        infos = {"metainfo": {"categories": {c: i for i, c in enumerate(CLASS_NAMES)}, "dataset": "simgen",
                              "info_version": INFO_VERSION}, "data_list": data_list}
        data = json.dumps(infos, separators=(",", ":")).encode()
        records.append(write_bytes(root, mmdet3d_info_path(split), data, len(data_list)))
    return records


class OpenPCDet(DatasetFormat):
    name = "openpcdet"
    carries = Carries(track_ids=False, point_fields=False, point_counts=False, units=True)
    frame_files = True

    def stream(self, root, clip, clip_index, sensors):
        return OpenPCDetClipStream(root, clip_index, sensors)

    def reader(self, files, manifest):
        return OpenPCDetReader(files, {c.clip: c.clip_index for c in manifest.clips}, manifest.sensors)

    def clip_files(self, entry: ClipEntry) -> set[str]:
        paths = (points_path, labels_path)
        return {f(entry.clip_index, i) for i in range(entry.frames) for f in paths}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        return set(IMAGE_SETS) | {mmdet3d_info_path(split) for split in MMDET3D_SPLITS}

    def finish(self, root: Path, clips: Sequence[ClipRecord], sensors, scenario: Mapping) -> list[FileRecord]:
        return write_image_sets(root, clips) + write_mmdet3d_infos(root, clips)

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
            *mmdet3d_card_lines(),
        ]

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        return lambda k, i: (str(root / labels_path(entry.clip_index, k)), i + 1)  # line number, from 1


FORMAT = OpenPCDet()
