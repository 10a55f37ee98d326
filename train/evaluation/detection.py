"""KITTI-style average precision of 3D boxes, in bird's-eye view (BEV) and 3D, on exact rotated IoU.

Per frame, detections in descending score are matched greedily, each to the still unmatched ground-
truth box of highest IoU (train.geometry: exact rotated BEV or 3D IoU) if that IoU is at least the
threshold (0.5): a true positive, else a false positive. AP follows KITTI's official evaluation
(kitti_object_eval_python, OpenPCDet's): score thresholds at the recall levels 0, 1/40, ..., 1 are
taken from the true positives' scores, the last true positive's always among them, so the level
nearest the maximum recall is credited even where the recall stops between two levels; precision at
each threshold is that of the detections scoring at least it, interpolated as the best at that
threshold or any lower one. R40 averages levels 1/40..1 (KITTI since 2019), R11 levels 0, 0.1, ...,
1 (the original devkit), in percent. Labelled boxes may be marked ignored (e.g. without points): a
detection matched to one is neither a true nor a false positive, as KITTI does with the boxes
outside a difficulty level. Beside IoU, a pitch-plane centre distance (`centre`, a threshold in
metres) can decide a match. There are no DontCare regions; the official code keeps a pair at IoU >
0.5 where this one keeps IoU >= 0.5, and it matches each ground-truth box to a detection in its own
order: equal results wherever each detection overlaps one box. As in the official code, few ground-
truth boxes make AP coarse (a perfect detector of 40 boxes reads 97.5 at R40: one threshold is spent
on level 0).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from train.evaluation.recall_levels import level_thresholds
from train.geometry import bev_iou_pairs, iou_3d_pairs


def centre_closeness_pairs(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """(N,) minus the BEV (pitch-plane) distance in metres of the centres of row i of a and b (N, 7)."""
    return -np.linalg.norm(np.asarray(a, np.float64)[:, :2] - np.asarray(b, np.float64)[:, :2], axis=-1)


# Similarity of paired detected and labelled boxes; a pair matches at or above the threshold (for
# "centre": a distance in metres, matched at or below it).
PAIR_FUNCTIONS: dict[str, Callable[[NDArray, NDArray], NDArray[np.float64]]] = {
    "bev": bev_iou_pairs, "3d": iou_3d_pairs, "centre": centre_closeness_pairs,
}
RECALL_POINTS = (40, 11)
SAMPLE_LEVELS = 40  # thresholds at recall 0, 1/40, ..., 1; R11 reads every fourth


@dataclass(frozen=True)
class FrameBoxes:
    """One frame's detections and ground truth for one box of the tracklet (t, t-1 or t-2)."""

    boxes: NDArray[np.float32]  # (N, 7) detected
    scores: NDArray[np.float32]  # (N,)
    truth: NDArray[np.float32]  # (G, 7) labelled
    # (G,) labelled boxes that count neither way (a detection on one is dropped)
    ignore: NDArray[np.bool_] | None = None
    # (N,) detections that count only where they match a counted box (unmatched, they are dropped): KITTI's rule
    # for the detections outside a difficulty level, here outside a distance bin
    ignore_unmatched: NDArray[np.bool_] | None = None

    @property
    def counted_truth(self) -> int:
        return len(self.truth) if self.ignore is None else int(np.count_nonzero(~self.ignore))


def similarities(frames: Sequence[FrameBoxes], iou_kind: str) -> list[NDArray[np.float64]]:
    """Per frame, (N, G) similarity of its detections and labelled boxes: every frame's pairs in one
    call (thousands of small per-frame calls cost more than the geometry)."""
    sizes = [(len(f.boxes), len(f.truth)) for f in frames]
    detected = np.concatenate(
        [np.repeat(np.asarray(f.boxes, np.float64).reshape(-1, 7), g, axis=0) for f, (_, g) in zip(frames, sizes)]
        or [np.zeros((0, 7))]
    )
    truth = np.concatenate(
        [np.tile(np.asarray(f.truth, np.float64).reshape(-1, 7), (n, 1)) for f, (n, _) in zip(frames, sizes)]
        or [np.zeros((0, 7))]
    )
    flat = PAIR_FUNCTIONS[iou_kind](detected, truth)
    ends = np.cumsum([n * g for n, g in sizes])
    return [block.reshape(n, g) for block, (n, g) in zip(np.split(flat, ends[:-1]), sizes)]


def _match(
    frame: FrameBoxes, similarity: NDArray[np.float64], threshold: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """(N,) true positives and (N,) detections matched to an ignored box, in the input order; `similarity`
    (N, G) at or above `threshold` matches."""
    tp, dropped = np.zeros(len(frame.boxes), bool), np.zeros(len(frame.boxes), bool)
    if len(frame.boxes) == 0 or len(frame.truth) == 0:
        return tp, dropped
    ignore = np.zeros(len(frame.truth), bool) if frame.ignore is None else frame.ignore
    rank = np.empty(len(frame.boxes), np.int64)
    rank[np.argsort(-frame.scores, kind="stable")] = np.arange(len(frame.boxes))
    # The pairs at or above the threshold (the others match nothing, whatever is taken), each detection's
    # in the order it tries them: detections by score, then truth by similarity (the first index on ties).
    det, truth = np.nonzero(similarity >= threshold)
    pairs = np.lexsort((truth, -similarity[det, truth], rank[det]))
    taken, decided = set(), set()
    for i, g in zip(det[pairs].tolist(), truth[pairs].tolist()):
        if i not in decided and g not in taken:
            taken.add(g)
            decided.add(i)
            tp[i], dropped[i] = not ignore[g], ignore[g]
    return tp, dropped


def _threshold(iou_kind: str, threshold: float) -> float:
    return -threshold if iou_kind == "centre" else threshold  # centre similarity is minus the distance


def match_frame(frame: FrameBoxes, iou_kind: str, threshold: float) -> NDArray[np.bool_]:
    """(N,) True for each detection that is a true positive, in the input order."""
    return _match(frame, similarities([frame], iou_kind)[0], _threshold(iou_kind, threshold))[0]


def average_precision(scores: NDArray[np.float32], tp: NDArray[np.bool_], num_truth: int, recall_points: int) -> float:
    """AP in percent from all detections' scores and true-positive flags and the ground-truth count.

    KITTI's rule (kitti_object_eval_python, as OpenPCDet runs it): score thresholds at the 41 recall
    levels 0, 1/40, ..., 1 from the true positives' scores (train.evaluation.recall_levels, the last true
    positive's score always among them); at each, precision of the detections scoring at least
    it, then the best precision at that threshold or a lower one. R40 averages levels 1/40..1, R11
    levels 0, 0.1, ..., 1; levels past the last threshold add 0.
    """
    if recall_points not in RECALL_POINTS:
        raise ValueError(f"recall_points must be one of {RECALL_POINTS}, got {recall_points}")
    if num_truth == 0:
        return float("nan")
    scores, tp = np.asarray(scores, np.float64), np.asarray(tp, bool)
    thresholds = np.array([s for s, _ in level_thresholds(scores[tp], num_truth, SAMPLE_LEVELS)][: SAMPLE_LEVELS + 1])
    if len(thresholds) == 0:
        return 0.0
    order = np.argsort(-scores, kind="stable")
    hits = np.cumsum(tp[order])
    kept = np.searchsorted(-scores[order], -thresholds, side="right")  # detections scoring >= each threshold
    precision = np.zeros(SAMPLE_LEVELS + 1)
    precision[: len(thresholds)] = np.maximum.accumulate((hits[kept - 1] / kept)[::-1])[::-1]
    chosen = precision[1:] if recall_points == 40 else precision[:: SAMPLE_LEVELS // 10]
    return float(100.0 * chosen.mean())


def detection_aps(
    frames: Sequence[FrameBoxes],
    iou_kind: str,
    threshold: float = 0.5,
    recall_points: Sequence[int] = RECALL_POINTS,
    similarity: list[NDArray[np.float64]] | None = None,
) -> list[float]:
    """AP in percent over frames at each of `recall_points`, with IoU `iou_kind` ('bev' or '3d') at
    `threshold`, or 'centre' within `threshold` metres; detections on ignored labelled boxes are left
    out, and so are the unmatched ones marked `ignore_unmatched`. `similarity`: the frames' `similarities` for
    `iou_kind`, when the caller has them already."""
    similarity = similarities(frames, iou_kind) if similarity is None else similarity
    matched = [_match(f, m, _threshold(iou_kind, threshold)) for f, m in zip(frames, similarity)]
    matched = [(tp, dropped if f.ignore_unmatched is None else dropped | (f.ignore_unmatched & ~tp))
               for f, (tp, dropped) in zip(frames, matched)]
    if not frames:
        return [average_precision(np.zeros(0, np.float32), np.zeros(0, bool), 0, points) for points in recall_points]
    scores = np.concatenate([f.scores[~dropped] for f, (_, dropped) in zip(frames, matched)])
    tps = np.concatenate([tp[~dropped] for tp, dropped in matched])
    truth = sum(f.counted_truth for f in frames)
    return [average_precision(scores, tps, truth, points) for points in recall_points]


def detection_ap(frames: Sequence[FrameBoxes], iou_kind: str, threshold: float = 0.5, recall_points: int = 40) -> float:
    """AP in percent over frames (`detection_aps` at one number of recall points)."""
    return detection_aps(frames, iou_kind, threshold, (recall_points,))[0]
