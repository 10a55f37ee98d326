"""Detection AP of a model on a dataset split, for each box of the tracklet.

AP rows: each box of the tracklet (t, t-1, t-2), IoU 0.5 in BEV and 3D and pitch-plane centre
distance within 0.25, 0.5 and 1 m, R40 and R11, on all labelled boxes and on the *visible* ones
(at least one point in t-2..t; the others are ignored: a detection on one counts neither way). By distance
(`ap_by_distance`): BEV and 3D AP of the boxes at t per 10 m bin of distance from the dataset's sensor; by pitch zone
(`ap_by_zone`): the same in the paper's detection box and outside it (train.evaluation.zones).
"""

from __future__ import annotations

import csv
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

import simgen.datasets
from simgen.atomic import atomic_path
from train.config import TRACKLET_FRAMES, DetectorConfig
from train.data import Sample
from train.detector.inference import predict
from train.detector.model import Detector
from train.detector.postprocess import Detections
from train.evaluation.detection import RECALL_POINTS, FrameBoxes, detection_aps, similarities
from train.evaluation.zones import ZONES, zone_index

IOU_THRESHOLD = 0.5
CENTRE_THRESHOLDS_M = (0.25, 0.5, 1.0)
TRUTH_SETS = ("all", "visible")
MEANINGFUL_TRUTH = 40  # fewer ground-truth boxes make AP coarse
DISTANCE_BIN_M = 10.0  # bins of distance from the sensor (ap_by_distance)


@dataclass(frozen=True)
class ApRow:
    box: str  # "t", "t-1" or "t-2"
    iou: str  # "bev", "3d" (IoU >= threshold) or "centre" (BEV centre distance <= threshold metres)
    recall_points: int  # 40 or 11
    ap: float  # percent
    truth: int  # ground-truth boxes counted
    detections: int
    threshold: float = IOU_THRESHOLD
    truth_set: str = "all"  # or "visible"


def box_name(offset: int) -> str:
    return "t" if offset == 0 else f"t{offset}"


def average_precisions(
    results: list[tuple[Sample, Detections]], visible: list[NDArray[np.bool_]] | None = None
) -> list[ApRow]:
    """AP of the boxes at t and, for tracklet models, at t-1 and t-2: BEV and 3D IoU, centre distance,
    40 and 11 points; on all labelled boxes and, given `visible` (per sample, (G,)), on the visible ones."""
    boxes = results[0][1].boxes.shape[1] if results else 1
    measures = [("bev", IOU_THRESHOLD), ("3d", IOU_THRESHOLD)] + [("centre", d) for d in CENTRE_THRESHOLDS_M]
    rows = []
    for k in range(boxes):
        offset = k - boxes + 1
        at = TRACKLET_FRAMES - 1 + offset
        similarity: dict[str, list] = {}  # per kind, the same for every truth set (they differ in what is ignored)
        for truth_set in TRUTH_SETS[: 1 if visible is None else 2]:
            frames = [
                FrameBoxes(d.boxes[:, k], d.scores, s.boxes[s.box_mask[:, at], at],
                           None if truth_set == "all" else ~visible[i][s.box_mask[:, at]])
                for i, (s, d) in enumerate(results)
            ]
            truth, count = sum(f.counted_truth for f in frames), sum(len(f.boxes) for f in frames)
            for kind, threshold in measures:
                if kind not in similarity:
                    similarity[kind] = similarities(frames, kind)
                aps = detection_aps(frames, kind, threshold, RECALL_POINTS, similarity[kind])
                rows += [ApRow(box_name(offset), kind, points, ap, truth, count, threshold, truth_set)
                         for points, ap in zip(RECALL_POINTS, aps)]
    return sorted(rows, key=lambda r: (r.truth_set, r.box != "t", r.box, r.iou, r.threshold, r.recall_points))


def _points_in_boxes(points_m: NDArray[np.float32], boxes: NDArray[np.float32]) -> NDArray[np.int64]:
    """(H,) points (P, 3) inside each box (H, 7)."""
    rel = np.asarray(points_m, np.float64)[None] - np.asarray(boxes, np.float64)[:, None, :3]  # (H, P, 3)
    cos, sin = np.cos(boxes[:, 6])[:, None], np.sin(boxes[:, 6])[:, None]
    along, across = cos * rel[..., 0] + sin * rel[..., 1], -sin * rel[..., 0] + cos * rel[..., 1]
    half = 0.5 * np.asarray(boxes, np.float64)[:, None, 3:6]
    inside = (np.abs(along) <= half[..., 0]) & (np.abs(across) <= half[..., 1]) & (np.abs(rel[..., 2]) <= half[..., 2])
    return inside.sum(axis=1)


def _frame_points(dataset: simgen.datasets.Dataset, clip: str, index: int) -> dict[int, int]:
    """Track id -> points on that object in one frame (the labels' count, else the points in its box)."""
    frame = dataset.frame(clip, index)
    counts = frame.num_points if frame.num_points is not None else _points_in_boxes(frame.points_m, frame.boxes)
    return dict(zip(np.asarray(frame.track_id).tolist(), np.asarray(counts).tolist()))


def object_points(dataset: simgen.datasets.Dataset, samples: list[Sample]) -> list[NDArray[np.int64]]:
    """Per sample, (G, 3): the points on each of its objects in frames t-2, t-1 and t (0 where it has no label)."""
    cache: dict[tuple[str, int], dict[int, int]] = {}
    out = []
    for sample in samples:
        counts = np.zeros((len(sample.track_id), TRACKLET_FRAMES), np.int64)
        for k, index in enumerate(range(sample.index - TRACKLET_FRAMES + 1, sample.index + 1)):
            key = (sample.clip, index)
            if key not in cache:
                cache[key] = _frame_points(dataset, *key)
            counts[:, k] = [cache[key].get(int(t), 0) for t in sample.track_id]
        out.append(counts)
    return out


def visible_objects(dataset: simgen.datasets.Dataset, samples: list[Sample]) -> list[NDArray[np.bool_]]:
    """Per sample, (G,): its objects with at least one point in frames t-2..t."""
    return [counts.sum(axis=1) > 0 for counts in object_points(dataset, samples)]


def sensor_positions(dataset: simgen.datasets.Dataset) -> NDArray[np.float64]:
    """(S, 2) the x, y of each of the dataset's sensors (its manifest), pitch frame, metres."""
    return np.array([sensor.origin_m[:2] for sensor in dataset.manifest.sensors], np.float64).reshape(-1, 2)


def sensor_distance_m(boxes: NDArray[np.float32], sensors_xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N,) pitch-plane distance of each box's centre (N, 7) from the nearest sensor (S, 2), metres."""
    offsets = np.asarray(boxes, np.float64).reshape(-1, 7)[:, None, :2] - np.asarray(sensors_xy, np.float64)[None]
    return np.linalg.norm(offsets, axis=-1).min(axis=1, initial=np.inf)


@dataclass(frozen=True)
class RegionAp:
    """AP of the boxes at t in one region: a bin of distance from the sensor (DistanceRow) or a pitch zone (ZoneRow)."""

    iou: str  # "bev" or "3d", IoU >= IOU_THRESHOLD
    recall_points: int  # 40 or 11
    ap: float  # percent
    truth: int  # labelled boxes in the region
    detections: int  # detections whose own centre is in the region
    median_points: float  # points on a labelled box of the region in its frame t; NaN where not given
    seen_t: float  # share of the region's labelled boxes with a point at t; NaN where not given
    seen_window: float  # share with a point in t-2..t (the visible ones); NaN where not given


@dataclass(frozen=True)
class DistanceRow(RegionAp):
    """AP in one bin of distance from the sensor, [low_m, high_m)."""

    low_m: float
    high_m: float


@dataclass(frozen=True)
class ZoneRow(RegionAp):
    """AP in one pitch zone (train.evaluation.zones.ZONES)."""

    zone: str


def _ap_by_region(
    results: list[tuple[Sample, Detections]], region_of: Callable[[NDArray], NDArray[np.int64]],
    points: list[NDArray[np.int64]] | None,
) -> list[tuple]:
    """Per region of the boxes at t (`region_of`: boxes (N, 7) -> (N,) region numbers), for BEV and 3D, R40 and R11:
    (region, iou, recall points, AP, labelled boxes, detections, median points, seen at t, seen in t-2..t), regions
    in increasing order, those with no labelled box left out. Each region is scored over every frame with all
    detections and labelled boxes matched as everywhere (train.evaluation.detection): labelled boxes outside it are
    ignored (a detection matched to one counts neither way) and a detection that matches no counted box is a false
    positive only where its own centre is in the region (KITTI's rule for difficulty levels)."""
    at = TRACKLET_FRAMES - 1
    truth = [s.boxes[s.box_mask[:, at], at] for s, _ in results]
    base = [FrameBoxes(d.boxes[:, -1], d.scores, g) for (_, d), g in zip(results, truth)]
    truth_region = [region_of(g) for g in truth]
    found_region = [region_of(f.boxes) for f in base]
    counts = (np.concatenate([p[s.box_mask[:, at]] for p, (s, _) in zip(points, results)])
              if points is not None and results else None)  # (all boxes at t, 3)
    all_regions = np.concatenate(truth_region) if truth_region else np.zeros(0, np.int64)
    similarity = {kind: similarities(base, kind) for kind in ("bev", "3d")}
    rows = []
    for k in np.unique(all_regions).tolist():
        frames = [replace(f, ignore=tr != k, ignore_unmatched=fr != k) for f, tr, fr in zip(base, truth_region,
                                                                                               found_region)]
        inside = None if counts is None else counts[all_regions == k]
        median, seen_t, seen_window = (float("nan"),) * 3 if inside is None else (
            float(np.median(inside[:, -1])), float(np.mean(inside[:, -1] > 0)), float(np.mean(inside.sum(axis=1) > 0)))
        truth_count = int(np.count_nonzero(all_regions == k))
        found = sum(int(np.count_nonzero(fr == k)) for fr in found_region)
        for kind in ("bev", "3d"):
            aps = detection_aps(frames, kind, IOU_THRESHOLD, RECALL_POINTS, similarity[kind])
            rows += [(k, kind, n, ap, truth_count, found, median, seen_t, seen_window)
                     for n, ap in zip(RECALL_POINTS, aps)]
    return rows


def ap_by_distance(
    results: list[tuple[Sample, Detections]], sensors_xy: NDArray[np.float64], bin_m: float = DISTANCE_BIN_M,
    points: list[NDArray[np.int64]] | None = None,
) -> list[DistanceRow]:
    """BEV and 3D AP (IoU 0.5, R40 and R11) of the boxes at t, per bin of distance from the sensor.

    A box's distance is its centre's pitch-plane distance from the nearest sensor (`sensor_distance_m`); bin k
    holds the distances in [k bin_m, (k + 1) bin_m), scored as `_ap_by_region` says: each labelled box counts in
    exactly one bin, and a detection whose centre crossed a bin edge from its box's still counts for that box.
    Bins from 0 m to the farthest labelled box; bins with no labelled box are left out (AP is undefined there).
    `points`: per sample, (G, 3) from `object_points`, for the points columns.
    """
    def bin_of(boxes: NDArray) -> NDArray[np.int64]:
        return np.floor(sensor_distance_m(boxes, sensors_xy) / bin_m).astype(np.int64)

    rows = _ap_by_region(results, bin_of, points)
    return [DistanceRow(*rest, low_m=k * bin_m, high_m=(k + 1) * bin_m) for k, *rest in rows]


def ap_by_zone(
    results: list[tuple[Sample, Detections]], points: list[NDArray[np.int64]] | None = None
) -> list[ZoneRow]:
    """BEV and 3D AP (IoU 0.5, R40 and R11) of the boxes at t in each pitch zone (train.evaluation.zones: the
    paper's detection box and outside it), scored as `_ap_by_region` says; `points` as for `ap_by_distance`."""
    return [ZoneRow(*rest, zone=ZONES[k]) for k, *rest in _ap_by_region(results, zone_index, points)]


def write_ap_csv(path: Path, rows: list[ApRow], extra: dict[str, str]) -> None:
    """The rows as CSV, each with the `extra` columns first; written atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow([*extra, "truth_set", "box", "iou", "threshold", "recall_points", "ap", "truth", "detections"])
        for r in rows:
            writer.writerow([*extra.values(), r.truth_set, r.box, r.iou, r.threshold, r.recall_points, f"{r.ap:.2f}",
                             r.truth, r.detections])


def _write_region_csv(path: Path, region: dict[str, Callable], rows: list[RegionAp], extra: dict[str, str]) -> None:
    """Rows of AP by region as CSV: the `extra` columns, then `region`'s (name -> cell of a row), then the AP's;
    written atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow([*extra, *region, "iou", "threshold", "recall_points", "ap", "truth", "detections",
                         "median_points", "seen_t", "seen_window"])
        for r in rows:
            writer.writerow([*extra.values(), *(cell(r) for cell in region.values()), r.iou, IOU_THRESHOLD,
                             r.recall_points, f"{r.ap:.2f}", r.truth, r.detections, f"{r.median_points:g}",
                             f"{r.seen_t:.3f}", f"{r.seen_window:.3f}"])


def write_distance_csv(path: Path, rows: list[DistanceRow], extra: dict[str, str]) -> None:
    """`ap_by_distance`'s rows as CSV, each with the `extra` columns first; written atomically."""
    _write_region_csv(path, {"low_m": lambda r: f"{r.low_m:g}", "high_m": lambda r: f"{r.high_m:g}"}, rows, extra)


def write_zone_csv(path: Path, rows: list[ZoneRow], extra: dict[str, str]) -> None:
    """`ap_by_zone`'s rows as CSV, each with the `extra` columns first; written atomically."""
    _write_region_csv(path, {"zone": lambda r: r.zone}, rows, extra)


def _region_table(heading: str, rows: list[RegionAp], name: Callable[[RegionAp], str], regions: str) -> str:
    """One line per region, in the rows' order (`name`: a row's region): 3D and BEV AP R40, the labelled boxes, the
    detections, the median points per box at t and the share of boxes with a point at t and in t-2..t."""
    lines = [f"{heading:<26} 3D AP@R40  BEV AP@R40  truth  detections  median points  seen t  seen t-2..t"]
    bev = {name(r): r for r in rows if (r.iou, r.recall_points) == ("bev", 40)}
    for three in (r for r in rows if (r.iou, r.recall_points) == ("3d", 40)):
        lines.append(f"{name(three):<26} {three.ap:9.2f}  {bev[name(three)].ap:10.2f}  {three.truth:5d}  "
                     f"{three.detections:10d}  {three.median_points:13g}  {three.seen_t:6.1%}  "
                     f"{three.seen_window:11.1%}")
    if any(r.truth < MEANINGFUL_TRUTH for r in rows):
        lines.append(f"note: {regions} of fewer than {MEANINGFUL_TRUTH} labelled boxes give coarse AP")
    return "\n".join(lines)


def format_distance_table(rows: list[DistanceRow]) -> str:
    """`ap_by_distance`'s rows, one line per bin."""
    return _region_table("distance from the sensor", rows, lambda r: f"{r.low_m:g}-{r.high_m:g} m", "bins")


def format_zone_table(rows: list[ZoneRow]) -> str:
    """`ap_by_zone`'s rows, one line per zone."""
    return _region_table("pitch zone", rows, lambda r: r.zone, "zones")


def format_ap_table(rows: list[ApRow]) -> str:
    lines = ["truth    box  match          AP@R40  AP@R11  truth  detections"]
    for r in rows:
        if r.recall_points == 40:
            key = (r.truth_set, r.box, r.iou, r.threshold)
            r11 = next(x.ap for x in rows if (x.truth_set, x.box, x.iou, x.threshold, x.recall_points) == (*key, 11))
            lines.append(f"{r.truth_set:<8} {r.box:<4} {measure_name(r):<14} {r.ap:6.2f}  {r11:6.2f}  {r.truth:5d}  "
                         f"{r.detections:10d}")
    fewest = min((r.truth for r in rows), default=0)
    if fewest < MEANINGFUL_TRUTH:
        lines.append(f"note: {fewest} ground-truth boxes; AP moves in large steps under about {MEANINGFUL_TRUTH}")
    return "\n".join(lines)


@dataclass(frozen=True)
class EvalResult:
    rows: list[ApRow]
    frames_per_s: float  # inference (none for tracklet files), loading included
    distance: list[DistanceRow] | None = None  # given a bin width
    zone: list[ZoneRow] | None = None  # asked for


def score(results: list[tuple[Sample, Detections]], dataset: str, by_distance_m: float | None,
          start: float, by_zone: bool = False) -> EvalResult:
    """The AP rows of detections on samples of `dataset`, given a bin width in metres AP by distance from its
    sensor, and with `by_zone` AP by pitch zone; `start`: the `time.perf_counter()` at which reading began."""
    data = simgen.datasets.open(dataset)
    points = object_points(data, [s for s, _ in results])
    rows = average_precisions(results, [p.sum(axis=1) > 0 for p in points])
    distance = None if by_distance_m is None else ap_by_distance(results, sensor_positions(data), by_distance_m, points)
    zone = ap_by_zone(results, points) if by_zone else None
    return EvalResult(rows, len(results) / (time.perf_counter() - start), distance, zone)


def evaluate(model: Detector, config: DetectorConfig, dataset: str, split: str | None, device: torch.device,
             progress: bool = True, by_distance_m: float | None = None, by_zone: bool = False) -> EvalResult:
    start = time.perf_counter()
    return score(list(predict(model, config, dataset, split, device, progress)), dataset, by_distance_m, start,
                 by_zone)


def measure_name(row: ApRow) -> str:
    """`bev IoU 0.5`, `3d IoU 0.5` or `centre 0.25 m`."""
    return f"centre {row.threshold:g} m" if row.iou == "centre" else f"{row.iou} IoU {row.threshold:g}"


def mean_ap(rows: list[ApRow], iou: str, recall_points: int = 40, box: str = "t", threshold: float = IOU_THRESHOLD,
            truth_set: str = "all") -> float:
    key = (box, iou, recall_points, threshold, truth_set)
    return next((r.ap for r in rows if (r.box, r.iou, r.recall_points, r.threshold, r.truth_set) == key), float(np.nan))
