"""MMDetection3D's info files of an OpenPCDet dataset: a loader written here from the documented v2 layout
(simgen.datasets.formats.openpcdet) reads every sample, its points and its boxes, as the dataset reader gives them."""

from __future__ import annotations

import json

import numpy as np
import pytest

import simgen.datasets
from simgen.datasets.samples import sample_number
from tests.support.datasets import make_clip, write_dataset


def _mmdet3d_style_samples(root, split: str):
    """What MMDetection3D's Det3DDataset and LoadPointsFromFile(load_dim, use_dim=4) make of each info:
    (sample_idx, points (N, 4), boxes (H, 7) bottom-centred, labels (H,)), and the categories."""
    infos = json.loads((root / f"mmdet3d_infos_{split}.json").read_text())  # as mmengine.load reads a .json
    assert infos["metainfo"]["info_version"] == "1.1"
    out = []
    for info in infos["data_list"]:
        points = np.load(root / "points" / info["lidar_points"]["lidar_path"])
        load_dim = info["lidar_points"]["num_pts_feats"]
        points = points.reshape(-1, load_dim)[:, :4]
        boxes = np.array([i["bbox_3d"] for i in info["instances"]], np.float32).reshape(-1, 7)
        labels = np.array([i["bbox_label_3d"] for i in info["instances"]], np.int64)
        out.append((info["sample_idx"], points, boxes, labels))
    return out, infos["metainfo"]["categories"]


@pytest.mark.parametrize("clips", [1, 3])
def test_every_sample_reads_back_with_its_points_and_boxes(tmp_path, clips):
    write_dataset(tmp_path, "openpcdet", [make_clip(f"clip_{i:04d}", 5, points=80, seed=i) for i in range(clips)])
    data = simgen.datasets.open(tmp_path)
    seen = {}
    for split in ("train", "val"):
        samples, categories = _mmdet3d_style_samples(tmp_path, split)
        assert categories == {"Pedestrian": 0, "Official": 1} and samples  # val never empty
        listed = (tmp_path / "ImageSets" / f"{split}.txt").read_text().split()
        assert [s[0] for s in samples] == [int(name) for name in listed]
        seen.update({s[0]: (split, *s[1:]) for s in samples})
    indices = {c.clip: c.clip_index for c in data.manifest.clips}
    frames = {sample_number(indices[c], i): (c, i) for c in data.clips for i in range(data.num_frames(c))}
    assert sorted(seen) == sorted(frames)
    names = list(categories)
    for number, (split, points, boxes, labels) in seen.items():
        frame = data.frame(*frames[number])
        assert clips == 1 or split == data.split(frame.clip)  # one clip: its last frames are val
        np.testing.assert_array_equal(points[:, :3], frame.points_m)
        np.testing.assert_array_equal(np.rint(points[:, 3].astype(np.float64) * 255), frame.intensity)
        bottom = frame.boxes.copy()
        bottom[:, 2] -= frame.boxes[:, 5] / 2
        np.testing.assert_allclose(boxes, bottom, rtol=0, atol=1e-6)
        assert [names[k] for k in labels] == list(frame.class_name)
