"""Inference over a dataset split: each sample's tracklets (train.detector.streaming), and tracklet files."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import torch
from tqdm import tqdm

from train.config import DetectorConfig
from train.data import Sample, SampleSet
from train.detector.detections import clip_tracklets, write_kitti, write_tracklets
from train.detector.model import Detector
from train.detector.postprocess import Detections
from train.detector.streaming import stream


def predict(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device,
            progress: bool = True) -> Iterator[tuple[Sample, Detections]]:
    """Each sample of the split (frames with two before them), in clip and frame order, with its tracklets
    (train.detector.streaming: each frame's backbone once)."""
    samples = SampleSet(dataset, split, config)
    found = stream(model, config, samples, device)
    yield from tqdm(
        found, total=len(samples), desc=f"detect {config.name}", unit="frame", disable=not progress, dynamic_ncols=True
    )


def detect(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device, out: Path,
           progress: bool = True) -> list[Path]:
    """Write `out/tracklets/<clip>.npz` and `out/kitti/<clip>/<frame>.txt`; return the tracklet files."""
    by_clip: dict[str, list[tuple[int, Detections]]] = {}
    for sample, found in predict(model, config, dataset, split, device, progress):
        by_clip.setdefault(sample.clip, []).append((sample.index, found))
    (out / "tracklets").mkdir(parents=True, exist_ok=True)
    written = []
    for clip, frames in by_clip.items():
        tracklets = clip_tracklets(
            clip, [f for f, _ in frames], [d.boxes for _, d in frames], [d.scores for _, d in frames]
        )
        path = out / "tracklets" / f"{clip}.npz"
        write_tracklets(path, tracklets)
        write_kitti(out / "kitti" / clip, tracklets, [f for f, _ in frames])
        written.append(path)
    return written
