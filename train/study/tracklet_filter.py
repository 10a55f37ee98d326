"""The tracklets the trackers get: a score threshold and a tight NMS, chosen on the train clips.

The detector's own output (train.detector.postprocess: score >= 0.1, NMS at BEV IoU 0.2) is for AP, which
rewards every candidate; a tracker fed all of them latches onto the false ones, many 0.3-1 m from
a player. The paper filters its tracklets by score before associating them, and OpenPCDet's
PointPillars suppresses at BEV IoU 0.01. Here the filter is a score threshold and greedy NMS on the
boxes at t, by BEV IoU or by BEV centre distance, chosen for each tracker.

Rule (``choose_filters``): every filter of GRID (score thresholds x NMS settings) is applied to the
tracklets of the *train* clips and each tracker tracks them; each tracker keeps the filter under
which it reaches its highest sAMOTA (3D IoU >= 0.25), ties to the earlier one in GRID. A tracker is
thus compared at its own best input, not at another tracker's. The val clips are never looked at.
"""

from __future__ import annotations

import csv
import functools
import multiprocessing
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from simgen.errors import UserError
from train.detector.nms import nms_bev, nms_centre
from train.evaluation.tracking import evaluate_tracking
from train.tracking.clip import make_tracker, track_clip
from train.tracking.config import TrackerConfig
from train.tracking.types import GroundTruthFrame, Tracklets


@dataclass(frozen=True)
class TrackletFilter:
    """Score at least ``min_score``, then greedy NMS on the boxes at t: a box goes when its BEV IoU
    with a kept one is above ``nms_threshold`` (``bev_iou``), or its centre is closer than
    ``nms_threshold`` metres (``centre``)."""

    min_score: float
    nms: Literal["bev_iou", "centre"]
    nms_threshold: float

    @property
    def label(self) -> str:
        rule = f"BEV IoU > {self.nms_threshold:g}" if self.nms == "bev_iou" else f"centres < {self.nms_threshold:g} m"
        return f"score >= {self.min_score:g}, NMS {rule}"


SCORE_THRESHOLDS = (0.1, 0.2, 0.3, 0.4, 0.5)
NMS_SETTINGS: tuple[tuple[Literal["bev_iou", "centre"], float], ...] = (
    ("bev_iou", 0.2), ("bev_iou", 0.01), ("centre", 0.5), ("centre", 1.0),
)
GRID = tuple(TrackletFilter(s, kind, value) for s, (kind, value) in product(SCORE_THRESHOLDS, NMS_SETTINGS))


def filter_tracklets(
    boxes: NDArray[np.float64], scores: NDArray[np.float64], rule: TrackletFilter
) -> NDArray[np.int64]:
    """Indices, best score first, of the tracklets (N, K, 7) with scores (N,) that `rule` keeps."""
    above = np.flatnonzero(scores >= rule.min_score)
    nms = nms_bev if rule.nms == "bev_iou" else nms_centre
    return above[nms(boxes[above, -1], scores[above], rule.nms_threshold, len(above))]


def apply_filter(frames: Sequence[Tracklets], rule: TrackletFilter) -> list[Tracklets]:
    """A clip's tracklets, frame by frame, as the filter leaves them."""
    kept = [filter_tracklets(f.boxes, f.scores, rule) for f in frames]
    return [Tracklets(f.boxes[k], f.scores[k]) for f, k in zip(frames, kept)]


def read_filters(path: Path) -> dict[str, TrackletFilter]:
    """Tracker name -> the filter of GRID a study's table2.csv names for it (its `filtered` rows)."""
    by_label = {rule.label: rule for rule in GRID}
    try:
        with open(path, newline="") as table:
            rows = [r for r in csv.DictReader(table) if r.get("tracklets") == "filtered"]
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise UserError(f"{path}: not a study's table2.csv ({error.__class__.__name__})") from None
    if not rows or any(r.get("filter") not in by_label or not r.get("tracker") for r in rows):
        raise UserError(f"{path}: not a study's table2.csv (no 'filtered' rows naming a filter of the grid)")
    return {r["tracker"]: by_label[r["filter"]] for r in rows}


@dataclass(frozen=True)
class FilterScore:
    rule: TrackletFilter
    samota: float  # of one tracker on the train clips, IoU 0.25
    tracklets_per_frame: float


def score_filter(
    rule: TrackletFilter,
    clips: Sequence[Sequence[Tracklets]],
    truth: Sequence[Sequence[GroundTruthFrame]],
    trackers: Sequence[TrackerConfig],
) -> list[FilterScore]:
    """Each tracker's sAMOTA (IoU 0.25) on `clips` filtered by `rule`, in `trackers` order."""
    kept = [apply_filter(c, rule) for c in clips]
    count = sum(len(f.scores) for c in kept for f in c) / max(1, sum(len(c) for c in kept))
    return [
        FilterScore(rule, evaluate_tracking(truth, [track_clip(make_tracker(tracker), c) for c in kept]).samota, count)
        for tracker in trackers
    ]


def choose_filters(
    clips: Sequence[Sequence[Tracklets]],
    truth: Sequence[Sequence[GroundTruthFrame]],
    trackers: Sequence[TrackerConfig],
    grid: Sequence[TrackletFilter] = GRID,
    progress: bool = False,
    workers: int = 1,
) -> dict[str, tuple[TrackletFilter, list[FilterScore]]]:
    """Tracker name -> the filter of `grid` under which it tracks `clips` best (sAMOTA), and every filter's score.

    With `workers` > 1 the filters are scored in that many spawned processes (each filter independent of the
    others; the same scores as in one process).
    """
    score = functools.partial(score_filter, clips=clips, truth=truth, trackers=trackers)
    bar = functools.partial(tqdm, total=len(grid), desc="choose tracklet filters", unit="filter",
                            disable=not progress, dynamic_ncols=True)
    if workers > 1 and len(grid) > 1:
        context = multiprocessing.get_context("spawn")  # the caller may hold torch's threads: no fork
        with ProcessPoolExecutor(min(workers, len(grid)), mp_context=context) as pool:
            by_filter = list(bar(pool.map(score, grid)))
    else:
        by_filter = list(bar(map(score, grid)))
    chosen = {}
    for k, tracker in enumerate(trackers):
        by_rule = [scores[k] for scores in by_filter]
        best = max(range(len(by_rule)), key=lambda i: (by_rule[i].samota, -i))
        chosen[tracker.name] = (grid[best], by_rule)
    return chosen
