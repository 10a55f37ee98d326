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
from train.geometry import iou_3d_pairs
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


def _frame_ious(gt_clip: Clip, track_clip: TrackedClip) -> list[NDArray[np.float64]]:
    """Each frame's (G, T) 3D IoU of ground truth and tracker boxes, all the clip's pairs in one call."""
    shapes = [(len(gt.ids), len(out.ids)) for gt, out in zip(gt_clip, track_clip)]
    pairs = [(np.repeat(gt.boxes, len(out.ids), axis=0), np.tile(out.boxes, (len(gt.ids), 1)))
             for gt, out in zip(gt_clip, track_clip)]
    if not pairs:
        return []
    flat = iou_3d_pairs(np.concatenate([a for a, _ in pairs]), np.concatenate([b for _, b in pairs]))
    ends = np.cumsum([g * n for g, n in shapes])
    return [part.reshape(shape) for part, shape in zip(np.split(flat, ends[:-1]), shapes)]


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
                _Frame(gt.ids, out.ids, iou, np.array([mean_score[k] for k in out.ids.tolist()]))
                for gt, out, iou in zip(gt_clip, track_clip, _frame_ious(gt_clip, track_clip))
            ]
        )
    return clips


class _Counter:
    """CLEAR MOT counts of some clips at any score threshold, with what does not depend on it computed once.

    Ground-truth boxes and tracker boxes become slots in flat arrays (clip, frame, box order), and the pairs at
    3D IoU >= min_iou one list. At a threshold, a frame whose kept pairs share no ground-truth box and no
    track is matched as they are: the Hungarian algorithm takes every such pair (each one it left out would add
    a forbidden cost), so only the other frames are matched by it. IDS and FRAG are counted along every
    ground-truth trajectory at once, on arrays.
    """

    def __init__(self, clips: list[list[_Frame]], min_iou: float) -> None:
        self.frames = [frame for frames in clips for frame in frames]
        self.min_iou = min_iou
        self.gt_start = np.concatenate([[0], np.cumsum([len(f.gt_ids) for f in self.frames], dtype=np.int64)])
        self.track_start = np.concatenate([[0], np.cumsum([len(f.track_ids) for f in self.frames], dtype=np.int64)])
        self.track_ids = _flat([f.track_ids for f in self.frames], np.int64)
        self.track_scores = _flat([f.track_scores for f in self.frames], np.float64)
        pairs = [np.nonzero(f.iou >= min_iou) for f in self.frames]
        self.pair_frame = np.repeat(np.arange(len(self.frames)), [len(r) for r, _ in pairs])
        self.pair_gt = _flat([self.gt_start[k] + r for k, (r, _) in enumerate(pairs)], np.int64)
        self.pair_track = _flat([self.track_start[k] + c for k, (_, c) in enumerate(pairs)], np.int64)
        self.pair_iou = _flat([f.iou[r, c] for f, (r, c) in zip(self.frames, pairs)], np.float64)
        # Each ground-truth trajectory's slots in frame order, one trajectory after another.
        clip_of = np.repeat(np.arange(len(clips)), [sum(len(f.gt_ids) for f in frames) for frames in clips])
        gt_ids = _flat([f.gt_ids for f in self.frames], np.int64)
        self.order = np.lexsort((np.arange(len(gt_ids)), gt_ids, clip_of))
        self.first = np.ones(len(gt_ids), bool)
        self.first[1:] = (np.diff(clip_of[self.order]) != 0) | (np.diff(gt_ids[self.order]) != 0)

    def _hungarian(self, frame: int, keep: NDArray[np.bool_]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Ground-truth and track slots of a frame's matched pairs, by the Hungarian algorithm."""
        kept = np.flatnonzero(keep[self.track_start[frame] : self.track_start[frame + 1]])
        iou = self.frames[frame].iou[:, kept]
        rows, cols = linear_sum_assignment(np.where(iou >= self.min_iou, 1.0 - iou, _FORBIDDEN))
        good = iou[rows, cols] >= self.min_iou
        return self.gt_start[frame] + rows[good], self.track_start[frame] + kept[cols[good]]

    def matches(self, threshold: float) -> tuple[NDArray[np.bool_], NDArray[np.int64], NDArray[np.int64], float]:
        """With the tracks whose mean score is at least threshold: which track slots are kept, the ground-truth and
        track slots of the matched pairs, and their summed IoU."""
        keep = self.track_scores >= threshold
        kept = keep[self.pair_track]
        gt_degree = np.bincount(self.pair_gt[kept], minlength=self.gt_start[-1])
        track_degree = np.bincount(self.pair_track[kept], minlength=self.track_start[-1])
        shared = kept & ((gt_degree[self.pair_gt] > 1) | (track_degree[self.pair_track] > 1))
        hard = np.zeros(len(self.frames), bool)
        hard[self.pair_frame[shared]] = True
        easy = kept & ~hard[self.pair_frame]
        solved = [self._hungarian(k, keep) for k in np.flatnonzero(hard)]
        gt_slots = _flat([self.pair_gt[easy], *(g for g, _ in solved)], np.int64)
        track_slots = _flat([self.pair_track[easy], *(s for _, s in solved)], np.int64)
        iou_sum = float(self.pair_iou[easy].sum()) + sum(
            float(self.frames[k].iou[g - self.gt_start[k], s - self.track_start[k]].sum())
            for k, (g, s) in zip(np.flatnonzero(hard), solved)
        )
        return keep, gt_slots, track_slots, iou_sum

    def __call__(self, threshold: float) -> tuple[ClearMot, list[float]]:
        """Counts with the tracks whose mean score is at least threshold, and the true positives' scores."""
        keep, gt_slots, track_slots, iou_sum = self.matches(threshold)
        assigned = np.full(self.gt_start[-1], -1, np.int64)
        assigned[gt_slots] = self.track_ids[track_slots]
        ids, frag = _switches_and_fragments_laid_out(assigned[self.order], self.first)
        n_gt, tp = int(self.gt_start[-1]), len(gt_slots)
        counts = ClearMot(n_gt, tp, int(keep.sum()) - tp, n_gt - tp, ids, frag, iou_sum)
        return counts, self.track_scores[track_slots].tolist()


def _flat(parts: list[NDArray], dtype: type) -> NDArray:
    return np.concatenate(parts).astype(dtype, copy=False) if parts else np.zeros(0, dtype)


def _switches_and_fragments_laid_out(assigned: NDArray[np.int64], first: NDArray[np.bool_]) -> tuple[int, int]:
    """Summed IDS and FRAG (the module's rule) of trajectories laid end to end: assigned (N,), each frame's tracker
    id, -1 untracked; first (N,), where each trajectory starts."""
    n = len(assigned)
    if not n:
        return 0, 0
    index = np.arange(n)
    start = np.maximum.accumulate(np.where(first, index, 0))  # each position's trajectory start
    final = np.ones(n, bool)  # a trajectory's last position
    final[:-1] = first[1:]
    seen = np.maximum.accumulate(np.where(assigned != -1, index, -1))  # the latest tracked position so far
    seen_before = np.concatenate([[-1], seen[:-1]])
    last = np.where(seen_before >= start, assigned[np.maximum(seen_before, 0)], -1)  # the id last seen before
    before = np.concatenate([[-1], assigned[:-1]])
    after = np.concatenate([assigned[1:], [-1]])
    inner = ~first
    tracked = inner & (last != -1) & (assigned != -1)
    switches = tracked & (assigned != last) & (before != -1)
    fragments = tracked & ~final & (assigned != before) & (after != -1)
    fragments |= inner & final & (assigned != before) & (assigned != -1)
    return int(switches.sum()), int(fragments.sum())


def switches_and_fragments(assigned: Sequence[int]) -> tuple[int, int]:
    """IDS and FRAG of one ground-truth trajectory: its tracker id per frame, -1 where untracked."""
    first = np.zeros(len(assigned), bool)
    first[:1] = True
    return _switches_and_fragments_laid_out(np.asarray(assigned, np.int64), first)


def recall_thresholds(tp_scores: Sequence[float], n_gt: int, levels: int = RECALL_LEVELS) -> list[tuple[float, float]]:
    """(score threshold, recall level) pairs for levels 1/L, 2/L, ... as far as the scores reach.

    AB3DMOT's getThresholds (train.evaluation.recall_levels), level 0 dropped.
    """
    return level_thresholds(tp_scores, n_gt, levels)[1:]


def evaluate_tracking(
    ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip], min_iou: float = 0.25, levels: int = RECALL_LEVELS
) -> TrackingMetrics:
    """AB3DMOT's metrics over clips of ground truth and tracker output, frame for frame."""
    count = _Counter(_prepare(ground_truth, tracks), min_iou)
    everything, tp_scores = count(-np.inf)
    samota = amota = amotp = 0.0
    best_mota, best_threshold = 0.0, -np.inf
    thresholds = recall_thresholds(tp_scores, everything.n_gt, levels) if everything.n_gt else []
    for threshold, recall in thresholds:
        counts, _ = count(threshold)
        samota, amota, amotp = samota + counts.smota(recall), amota + counts.mota, amotp + counts.motp
        if counts.mota > best_mota:
            best_mota, best_threshold = counts.mota, threshold
    best = everything if best_threshold == -np.inf else count(best_threshold)[0]
    return TrackingMetrics(samota / levels, amota / levels, amotp / levels, best, best_threshold, len(thresholds))
