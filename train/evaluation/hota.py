"""HOTA (Luiten et al., 2021) on 3D boxes, as TrackEval computes it, with 3D IoU as the similarity.

Per clip: ids are matched frame by frame by the Hungarian algorithm on the similarity weighted by
the global alignment of the two ids over the clip; for each alpha = 0.05, 0.10, ..., 0.95, matches
with similarity >= alpha are true positives, DetA = TP / (TP + FN + FP), AssA = the mean over true
positives of TPA / (TPA + FNA + FPA) of their id pair, and HOTA_alpha = sqrt(DetA AssA). Clips are
combined as TrackEval does (counts summed, AssA and LocA weighted by TP); HOTA, DetA, AssA and LocA
are the means over alpha.

`centre_hota` is the same with a pitch-plane similarity, as SoccerNet's GS-HOTA scores game states:
exp(ln(0.05) d^2 / tau^2) for BEV centre distance d, tau = 5 m (1 at d = 0, 0.05 at 5 m).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from train.evaluation.tracking import Clip, TrackedClip
from train.geometry import iou_3d

ALPHAS = np.arange(0.05, 0.99, 0.05)
GS_TOLERANCE_M = 5.0  # SoccerNet GS-HOTA's tau
Similarity = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Hota:
    hota: float
    deta: float
    assa: float
    loca: float
    hota_per_alpha: NDArray[np.float64]  # (19,), for ALPHAS


@dataclass(frozen=True)
class _Counts:
    """Per alpha: TP, FN, FP, the TP-weighted sums of the association score and of the similarity."""

    tp: NDArray[np.float64]
    fn: NDArray[np.float64]
    fp: NDArray[np.float64]
    association: NDArray[np.float64]
    similarity: NDArray[np.float64]


def _dense_ids(ids: Sequence[NDArray[np.int64]]) -> tuple[list[NDArray[np.intp]], int]:
    unique, inverse = np.unique(np.concatenate([np.zeros(0, dtype=np.int64), *ids]), return_inverse=True)
    bounds = np.cumsum([0] + [len(i) for i in ids])
    return [inverse[a:b] for a, b in zip(bounds[:-1], bounds[1:])], len(unique)


def centre_similarity(
    a: NDArray[np.float64], b: NDArray[np.float64], tolerance_m: float = GS_TOLERANCE_M
) -> NDArray[np.float64]:
    """(P, Q) exp(ln(0.05) d^2 / tolerance^2) of the BEV centre distance d of boxes a (P, 7) and b (Q, 7)."""
    gap_sq = np.sum((np.asarray(a)[:, None, :2] - np.asarray(b)[None, :, :2]) ** 2, axis=-1)
    return np.exp(np.log(0.05) * gap_sq / tolerance_m**2)


def _clip_counts(gt_clip: Clip, track_clip: TrackedClip, similarity_of: Similarity) -> _Counts:
    gt_ids, n_gt = _dense_ids([f.ids for f in gt_clip])
    track_ids, n_track = _dense_ids([f.ids for f in track_clip])
    similarity = [similarity_of(g.boxes, t.boxes) for g, t in zip(gt_clip, track_clip)]
    potential = np.zeros((n_gt, n_track))
    gt_count, track_count = np.zeros((n_gt, 1)), np.zeros((1, n_track))
    for sim, g, t in zip(similarity, gt_ids, track_ids):
        denominator = sim.sum(0)[None, :] + sim.sum(1)[:, None] - sim
        potential[g[:, None], t[None, :]] += np.divide(
            sim, denominator, out=np.zeros_like(sim), where=denominator > _EPS
        )
        gt_count[g] += 1
        track_count[0, t] += 1
    alignment = potential / np.maximum(gt_count + track_count - potential, _EPS)
    tp, fn, fp, loc = (np.zeros(len(ALPHAS)) for _ in range(4))
    matches = np.zeros((len(ALPHAS), n_gt, n_track))
    for sim, g, t in zip(similarity, gt_ids, track_ids):
        rows, cols = linear_sum_assignment(-(alignment[g[:, None], t[None, :]] * sim))
        for a, alpha in enumerate(ALPHAS):
            ok = sim[rows, cols] >= alpha - _EPS
            tp[a] += ok.sum()
            fn[a] += len(g) - ok.sum()
            fp[a] += len(t) - ok.sum()
            loc[a] += sim[rows[ok], cols[ok]].sum()
            matches[a, g[rows[ok]], t[cols[ok]]] += 1
    pair_score = matches / np.maximum(1, gt_count + track_count - matches)
    return _Counts(tp, fn, fp, np.sum(matches * pair_score, axis=(1, 2)), loc)


def hota(ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip], similarity: Similarity = iou_3d) -> Hota:
    """HOTA and its parts over clips of ground truth and tracker output, frame for frame."""
    if len(ground_truth) != len(tracks) or any(len(g) != len(t) for g, t in zip(ground_truth, tracks)):
        raise ValueError("ground truth and tracks differ in number of clips or frames")
    counts = [_clip_counts(g, t, similarity) for g, t in zip(ground_truth, tracks)]
    tp, fn, fp = (sum(getattr(c, name) for c in counts) for name in ("tp", "fn", "fp"))
    assa = sum(c.association for c in counts) / np.maximum(1, tp)
    loca = np.maximum(1e-10, sum(c.similarity for c in counts)) / np.maximum(1e-10, tp)
    deta = tp / np.maximum(1, tp + fn + fp)
    per_alpha = np.sqrt(deta * assa)
    return Hota(float(per_alpha.mean()), float(deta.mean()), float(assa.mean()), float(loca.mean()), per_alpha)


def centre_hota(ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip]) -> Hota:
    """HOTA on the pitch plane: centre distance with GS-HOTA's 5 m Gaussian tolerance, no box shape."""
    return hota(ground_truth, tracks, centre_similarity)
