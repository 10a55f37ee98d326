"""KITTI detection files (a score column, one folder per clip) written from a dataset's labels, as another
detector's output would be: what `simgen-train track --detections` reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import simgen.datasets
from train.detector.detections import kitti_lines


def write_detections(dataset_path: Path, folder: Path, rng: np.random.Generator) -> int:
    """KITTI detection files of every clip from its labels: 5 cm of noise, a tenth of the boxes missing, random
    scores; returns the number of labelled tracks."""
    dataset = simgen.datasets.open(dataset_path)
    ids = set()
    for clip in dataset.clips:
        (folder / clip).mkdir(parents=True)
        for index in range(dataset.num_frames(clip)):
            frame = dataset.frame(clip, index)
            ids |= {(clip, i) for i in frame.track_id.tolist()}
            keep = rng.random(len(frame.boxes)) > 0.1
            boxes = frame.boxes[keep].copy()
            boxes[:, :3] += rng.normal(0, 0.05, (len(boxes), 3)).astype(np.float32)
            scores = rng.uniform(0.3, 1.0, len(boxes)).astype(np.float32)
            (folder / clip / f"{index:06d}.txt").write_text("".join(f"{line}\n" for line in kitti_lines(boxes, scores)))
    return len(ids)
