"""Inference over a dataset split, detection AP for each box of the tracklet, tracklet files."""

from __future__ import annotations

import csv
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from train.config import TRACKLET_FRAMES, DetectorConfig
from train.data import Sample, SampleSet, loader
from train.detections import clip_tracklets, write_kitti, write_tracklets
from train.metrics.detection import RECALL_POINTS, FrameBoxes, detection_ap
from train.models.detector import Detector
from train.postprocess import Detections, postprocess

IOU_THRESHOLD = 0.5
EVAL_BATCH = 2
MEANINGFUL_TRUTH = 40  # fewer ground-truth boxes make AP coarse


@dataclass(frozen=True)
class ApRow:
    box: str  # "t", "t-1" or "t-2"
    iou: str  # "bev" or "3d"
    recall_points: int  # 40 or 11
    ap: float  # percent
    truth: int  # ground-truth boxes
    detections: int


def predict(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device,
            progress: bool = True) -> Iterator[tuple[Sample, Detections]]:
    """Each sample of the split (frames with two before them), in clip and frame order, with its tracklets."""
    samples = SampleSet(dataset, split, config)
    model = model.to(device).eval()
    anchors = model.head.anchors
    batches = loader(samples, EVAL_BATCH, config.train.workers)
    total = -(-len(samples) // EVAL_BATCH)
    with torch.no_grad():
        for batch in tqdm(batches, total=total, desc=f"detect {config.name}", unit="batch", disable=not progress, dynamic_ncols=True):
            yield from zip(batch.samples, postprocess(model(batch.to(device)), anchors, config))


def box_name(offset: int) -> str:
    return "t" if offset == 0 else f"t{offset}"


def average_precisions(results: list[tuple[Sample, Detections]]) -> list[ApRow]:
    """AP of the boxes at t and, for tracklet models, at t-1 and t-2: BEV and 3D, 40 and 11 points."""
    boxes = results[0][1].boxes.shape[1] if results else 1
    rows = []
    for k in range(boxes):
        offset = k - boxes + 1
        frames = [
            FrameBoxes(d.boxes[:, k], d.scores, s.boxes[s.box_mask[:, TRACKLET_FRAMES - 1 + offset], TRACKLET_FRAMES - 1 + offset])
            for s, d in results
        ]
        truth, count = sum(len(f.truth) for f in frames), sum(len(f.boxes) for f in frames)
        for iou in ("bev", "3d"):
            for points in RECALL_POINTS:
                rows.append(ApRow(box_name(offset), iou, points, detection_ap(frames, iou, IOU_THRESHOLD, points), truth, count))
    return sorted(rows, key=lambda r: (r.box != "t", r.box, r.iou, r.recall_points))


def write_ap_csv(path: Path, rows: list[ApRow], extra: dict[str, str]) -> None:
    with open(path, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow([*extra, "box", "iou", "recall_points", "ap", "truth", "detections"])
        for r in rows:
            writer.writerow([*extra.values(), r.box, r.iou, r.recall_points, f"{r.ap:.2f}", r.truth, r.detections])


def format_ap_table(rows: list[ApRow]) -> str:
    lines = ["box  iou  AP@R40  AP@R11  truth  detections"]
    for r in rows:
        if r.recall_points == 40:
            r11 = next(x.ap for x in rows if (x.box, x.iou, x.recall_points) == (r.box, r.iou, 11))
            lines.append(f"{r.box:<4} {r.iou:<4} {r.ap:6.2f}  {r11:6.2f}  {r.truth:5d}  {r.detections:10d}")
    fewest = min((r.truth for r in rows), default=0)
    if fewest < MEANINGFUL_TRUTH:
        lines.append(f"note: {fewest} ground-truth boxes; AP moves in large steps under about {MEANINGFUL_TRUTH}")
    return "\n".join(lines)


@dataclass(frozen=True)
class EvalResult:
    rows: list[ApRow]
    frames_per_s: float  # inference, loading included


def evaluate(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device,
             progress: bool = True) -> EvalResult:
    start = time.perf_counter()
    results = list(predict(model, config, dataset, split, device, progress))
    return EvalResult(average_precisions(results), len(results) / (time.perf_counter() - start))


def detect(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device, out: Path,
           progress: bool = True) -> list[Path]:
    """Write `out/tracklets/<clip>.npz` and `out/kitti/<clip>/<frame>.txt`; return the tracklet files."""
    by_clip: dict[str, list[tuple[int, Detections]]] = {}
    for sample, found in predict(model, config, dataset, split, device, progress):
        by_clip.setdefault(sample.clip, []).append((sample.index, found))
    (out / "tracklets").mkdir(parents=True, exist_ok=True)
    written = []
    for clip, frames in by_clip.items():
        tracklets = clip_tracklets(clip, [f for f, _ in frames], [d.boxes for _, d in frames], [d.scores for _, d in frames])
        path = out / "tracklets" / f"{clip}.npz"
        write_tracklets(path, tracklets)
        write_kitti(out / "kitti" / clip, tracklets, [f for f, _ in frames])
        written.append(path)
    return written


def mean_ap(rows: list[ApRow], iou: str, recall_points: int = 40, box: str = "t") -> float:
    return next((r.ap for r in rows if (r.box, r.iou, r.recall_points) == (box, iou, recall_points)), float(np.nan))
