"""MMDetection3D's info files for an OpenPCDet dataset: `mmdet3d_infos_{train,val}.json`, its v2 info layout
(what `update_infos_to_v2` writes and its current `Det3DDataset` loads), beside the points they name.

JSON, not the .pkl its converters write: `mmengine.load`, which `Det3DDataset` reads its `ann_file` with, takes
either by the file's extension, and a simgen dataset holds no pickle (loading one can run code).

    {"metainfo": {"categories": {"Pedestrian": 0, "Official": 1}, "dataset": "simgen", "info_version": "1.1"},
     "data_list": [{"sample_idx": 10003,
                    "lidar_points": {"num_pts_feats": 5, "lidar_path": "010003.npy"},
                    "instances": [{"bbox_3d": [x, y, z, dx, dy, dz, yaw], "bbox_label_3d": 0}, ...]}, ...]}

`lidar_path` is relative to `data_prefix=dict(pts="points")` (`openpcdet.POINTS_DIR`); the points are
OpenPCDet's (N, 5) .npy (`LoadPointsFromFile(coord_type="LIDAR", load_dim=5, use_dim=4)`); `bbox_3d` is
MMDetection3D's LiDAR box: the centre of the box's bottom face (z = the box centre's - height / 2), length along
the heading, width, height, yaw counter-clockwise from +x, in the pitch frame.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simgen.datasets import openpcdet
from simgen.datasets.records import FileRecord, write_bytes
from simgen.datasets.samples import split_samples
from simgen.vocab import CLASS_NAMES

if TYPE_CHECKING:
    from simgen.datasets.records import ClipRecord

INFO_VERSION = "1.1"
SPLITS = ("train", "val")


def info_path(split: str) -> str:
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
        "lidar_points": {"num_pts_feats": len(openpcdet.COLUMNS), "lidar_path": openpcdet.points_file(name)},
        "instances": [{"bbox_3d": bbox_3d(box), "bbox_label_3d": labels[str(c)]} for box, c in zip(boxes, names)],
    }


def card_lines() -> list[str]:
    """The dataset card's MMDetection3D section."""
    classes = tuple(CLASS_NAMES)
    return [
        f"`{info_path('train')}` and `{info_path('val')}`: MMDetection3D's info files (its v2 layout, which",
        "`Det3DDataset` loads), the ImageSets' splits: per sample `sample_idx`, `lidar_points` (`lidar_path` under",
        f"`points/`, `num_pts_feats` {len(openpcdet.COLUMNS)}) and `instances` (`bbox_3d`: the LiDAR box, bottom-face",
        "centre x y z, length, width, height, yaw; `bbox_label_3d`: the index in `metainfo.categories`). JSON, which",
        "`mmengine.load` reads as it reads its .pkl infos. In MMDetection3D, a `Det3DDataset` subclass with",
        f"`METAINFO = {{'classes': {classes}}}` whose `parse_ann_info` wraps `gt_bboxes_3d` in `LiDARInstance3DBoxes`",
        "(and gives empty arrays for a sample with no box), `data_prefix=dict(pts='points')` and",
        f"`LoadPointsFromFile(coord_type='LIDAR', load_dim={len(openpcdet.COLUMNS)}, use_dim=4)` reads them.",
    ]


def write_infos(root: Path, clips: Sequence[ClipRecord]) -> list[FileRecord]:
    """Write the info file of each split from the labels the clips wrote under `root`; rows = samples."""
    records = []
    for split, names in split_samples(clips).items():
        data_list = []
        for name in names:
            labels = root / openpcdet.sample_labels_path(name)
            boxes, classes = openpcdet.parse_labels(labels.read_text(), labels)
            data_list.append(data_info(name, boxes, classes))
        infos = {"metainfo": {"categories": {c: i for i, c in enumerate(CLASS_NAMES)}, "dataset": "simgen",
                              "info_version": INFO_VERSION}, "data_list": data_list}
        data = json.dumps(infos, separators=(",", ":")).encode()
        records.append(write_bytes(root, info_path(split), data, len(data_list)))
    return records
