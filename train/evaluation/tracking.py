"""CLEAR MOT and AB3DMOT's recall-averaged metrics (sAMOTA, AMOTA, AMOTP) on 3D boxes.

This follows AB3DMOT's ``evaluate_kitti3dmot.py`` (the KITTI tracking devkit with 3D IoU), with no
DontCare areas, occlusion or truncation to ignore:

- Each frame, ground truth and tracker boxes are matched by the Hungarian algorithm on 1 - 3D IoU,
  pairs under ``min_iou`` (0.25) forbidden: the most matches, then the largest summed IoU. Matches
  are true positives, unmatched ground truth false negatives, unmatched tracker boxes false
  positives. MOTA = 1 - (FN + FP + IDS) / N_gt; MOTP = mean IoU of the matches.
- IDS and FRAG are counted along each ground-truth trajectory (its frames, in order) as KITTI does:
  an ID switch when the tracker id differs from the last one seen while both this frame and the
  previous one are tracked; a fragmentation when the id differs from the previous frame's (or that
  frame was untracked) after the trajectory was tracked once, and tracking goes on in the next
  frame; on the trajectory's last frame, whenever the id differs from the previous frame's.
- Scores: a track's score is the mean of its per-frame scores, and a threshold keeps or drops whole
  tracks. The thresholds are the scores of the true positives (all tracks kept) at which recall
  reaches r = 1/L, ..., 1 (L = 40), chosen as AB3DMOT's getThresholds does. At each level
  sMOTA_r = min(1, max(0, 1 - (IDS + FP + FN - (1 - r) N_gt) / (r N_gt))), and MOTA_r, MOTP_r as
  above; sAMOTA, AMOTA and AMOTP are their sums divided by L, levels never reached adding 0.
  The reported MOTA, MOTP, IDS and FRAG are those at the threshold of the best MOTA.

AMOTA: AB3DMOT's code (and the paper's tables, where AMOTA < 0.5) averages MOTA_r = 1 - (IDS + FP
+ FN) / N_gt, not (IDS + FP + FN) / (r N_gt); this module does the same. Recall levels are k / L
exactly, where AB3DMOT adds 1 / L in floating point.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from train.evaluation.recall_levels import level_thresholds
from train.geometry import iou_3d
from train.tracking.types import GroundTruthFrame, TrackedFrame

RECALL_LEVELS = 40
_FORBIDDEN = 1e9  # cost of a pair under min_iou, as in the devkit

Clip = Sequence[GroundTruthFrame]
TrackedClip = Sequence[TrackedFrame]


@dataclass(frozen=True)
class ClearMot:
    """CLEAR MOT counts over one or more clips; IoU sums are of 3D IoU."""

    n_gt: int
    tp: int
    fp: int
    fn: int
    ids: int
    frag: int
    iou_sum: float

    @property
    def mota(self) -> float:
        return 1.0 - (self.fn + self.fp + self.ids) / self.n_gt if self.n_gt else -np.inf

    @property
    def motp(self) -> float:
        return self.iou_sum / self.tp if self.tp else 0.0

    @property
    def recall(self) -> float:
        return self.tp / self.n_gt if self.n_gt else 0.0

    def smota(self, recall: float) -> float:
        """Scaled MOTA at recall level ``recall``, in [0, 1]."""
        if not self.n_gt:
            return -np.inf
        errors = self.fn + self.fp + self.ids - (1.0 - recall) * self.n_gt
        return min(1.0, max(0.0, 1.0 - errors / (recall * self.n_gt)))


@dataclass(frozen=True)
class TrackingMetrics:
    samota: float
    amota: float
    amotp: float
    best: ClearMot  # at best_threshold
    best_threshold: float  # of track mean scores; -inf keeps every track
    levels_reached: int  # of the RECALL_LEVELS


@dataclass(frozen=True)
class _Frame:
    """One frame's ground truth and tracker boxes with their IoU (G, T) and the track mean scores (T,)."""

    gt_ids: NDArray[np.int64]
    track_ids: NDArray[np.int64]  # non-negative
    iou: NDArray[np.float64]
    track_scores: NDArray[np.float64]


def _check_ids(ids: NDArray[np.int64], what: str, frame: int) -> None:
    if len(np.unique(ids)) != len(ids) or (ids < 0).any():
        raise ValueError(f"{what} ids must be unique and non-negative in a frame; frame {frame}: {ids.tolist()}")


def _prepare(ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip]) -> list[list[_Frame]]:
    if len(ground_truth) != len(tracks) or any(len(g) != len(t) for g, t in zip(ground_truth, tracks)):
        raise ValueError("ground truth and tracks differ in number of clips or frames")
    clips = []
    for gt_clip, track_clip in zip(ground_truth, tracks):
        per_track = defaultdict(list)
        for f, (gt, out) in enumerate(zip(gt_clip, track_clip)):
            _check_ids(gt.ids, "ground-truth", f)
            _check_ids(out.ids, "track", f)
            for track_id, score in zip(out.ids.tolist(), out.scores.tolist()):
                per_track[track_id].append(score)
        mean_score = {k: float(np.mean(v)) for k, v in per_track.items()}
        clips.append(
            [
                _Frame(
                    gt.ids, out.ids, iou_3d(gt.boxes, out.boxes), np.array([mean_score[k] for k in out.ids.tolist()])
                )
                for gt, out in zip(gt_clip, track_clip)
            ]
        )
    return clips


def switches_and_fragments(assigned: Sequence[int]) -> tuple[int, int]:
    """IDS and FRAG of one ground-truth trajectory: its tracker id per frame, -1 where untracked."""
    if len(assigned) < 2:
        return 0, 0
    switches = fragments = 0
    last = assigned[0]
    for f in range(1, len(assigned)):
        now, before = assigned[f], assigned[f - 1]
        if now != last and last != -1 and now != -1 and before != -1:
            switches += 1
        if f < len(assigned) - 1 and now != before and last != -1 and now != -1 and assigned[f + 1] != -1:
            fragments += 1
        if now != -1:
            last = now
    if assigned[-1] != assigned[-2] and assigned[-1] != -1:
        fragments += 1
    return switches, fragments


def _evaluate(clips: list[list[_Frame]], min_iou: float, threshold: float) -> tuple[ClearMot, list[float]]:
    """Counts with the tracks whose mean score is at least threshold, and the true positives' scores."""
    n_gt = tp = fp = ids = frag = 0
    iou_sum = 0.0
    tp_scores: list[float] = []
    for frames in clips:
        trajectories: dict[int, list[int]] = defaultdict(list)
        for frame in frames:
            keep = frame.track_scores >= threshold
            iou, track_ids = frame.iou[:, keep], frame.track_ids[keep]
            assigned = np.full(len(frame.gt_ids), -1)  # tracker id per ground-truth box; -1: missed
            rows, cols = linear_sum_assignment(np.where(iou >= min_iou, 1.0 - iou, _FORBIDDEN))
            good = iou[rows, cols] >= min_iou
            rows, cols = rows[good], cols[good]
            assigned[rows] = track_ids[cols]
            iou_sum += float(iou[rows, cols].sum())
            tp_scores.extend(frame.track_scores[keep][cols].tolist())
            n_gt, tp, fp = n_gt + len(frame.gt_ids), tp + len(rows), fp + len(track_ids) - len(rows)
            for gt_id, track_id in zip(frame.gt_ids.tolist(), assigned.tolist()):
                trajectories[gt_id].append(track_id)
        for assigned_ids in trajectories.values():
            s, f = switches_and_fragments(assigned_ids)
            ids, frag = ids + s, frag + f
    return ClearMot(n_gt, tp, fp, n_gt - tp, ids, frag, iou_sum), tp_scores


def recall_thresholds(tp_scores: Sequence[float], n_gt: int, levels: int = RECALL_LEVELS) -> list[tuple[float, float]]:
    """(score threshold, recall level) pairs for levels 1/L, 2/L, ... as far as the scores reach.

    AB3DMOT's getThresholds (train.evaluation.recall_levels), level 0 dropped.
    """
    return level_thresholds(tp_scores, n_gt, levels)[1:]


def evaluate_tracking(
    ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip], min_iou: float = 0.25, levels: int = RECALL_LEVELS
) -> TrackingMetrics:
    """AB3DMOT's metrics over clips of ground truth and tracker output, frame for frame."""
    clips = _prepare(ground_truth, tracks)
    everything, tp_scores = _evaluate(clips, min_iou, -np.inf)
    samota = amota = amotp = 0.0
    best_mota, best_threshold = 0.0, -np.inf
    thresholds = recall_thresholds(tp_scores, everything.n_gt, levels) if everything.n_gt else []
    for threshold, recall in thresholds:
        counts, _ = _evaluate(clips, min_iou, threshold)
        samota, amota, amotp = samota + counts.smota(recall), amota + counts.mota, amotp + counts.motp
        if counts.mota > best_mota:
            best_mota, best_threshold = counts.mota, threshold
    best = everything if best_threshold == -np.inf else _evaluate(clips, min_iou, best_threshold)[0]
    return TrackingMetrics(samota / levels, amota / levels, amotp / levels, best, best_threshold, len(thresholds))
