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
    counts = ClipCounts(n_gt, n_track)
    for sim, g, t in zip(similarity, gt_ids, track_ids):
        counts.align(sim, g, t)
    counts.aligned()
    for sim, g, t in zip(similarity, gt_ids, track_ids):
        counts.match(sim, g, t)
    return counts.counts()


class ClipCounts:
    """One clip's HOTA counts in two passes over its frames, in order: `align` each frame, `aligned`, then `match`
    each frame again; `counts`. Frames are (G, T) similarities with dense gt (G,) and track (T,) indices.

    Only the id pairs that ever meet are kept, as sorted arrays of pair keys and sums (not an n_gt x n_track matrix,
    nor a dict: 16 bytes a pair), merged every MERGE_ENTRIES new entries: memory grows with the pairs of ids alive
    together, not with the square of a long clip's ids. Every pair's sums are made in frame order, one addition at
    a time, as a dense matrix would make them.
    """

    MERGE_ENTRIES = 1 << 16

    def __init__(self, n_gt: int, n_track: int) -> None:
        self.n_track = n_track
        self.keys = np.zeros(0, np.int64)  # sorted pair keys g * n_track + t of the pairs met so far
        self.potential = np.zeros(0)  # each pair's summed per-frame alignment
        self._pending: list[tuple[NDArray[np.int64], NDArray[np.float64]]] = []  # since the last merge
        self._pending_entries = 0
        self.gt_count, self.track_count = np.zeros(n_gt), np.zeros(n_track)
        self.tp, self.fn, self.fp, self.loc = (np.zeros(len(ALPHAS)) for _ in range(4))
        self.matches: dict[int, NDArray[np.float64]] = {}  # pair key -> per alpha, frames matched

    def _keys(self, g: NDArray[np.intp], t: NDArray[np.intp]) -> NDArray[np.int64]:
        return g.astype(np.int64)[:, None] * self.n_track + t[None, :]

    def _merge(self) -> None:
        """The pending shares added to their pairs' sums: each sum first, then its shares in frame order (bincount
        adds in array order)."""
        if not self._pending:
            return
        keys = np.concatenate([self.keys, *(k for k, _ in self._pending)])
        values = np.concatenate([self.potential, *(v for _, v in self._pending)])
        self.keys, inverse = np.unique(keys, return_inverse=True)
        self.potential = np.bincount(inverse, weights=values, minlength=len(self.keys))
        self._pending, self._pending_entries = [], 0

    def align(self, sim: NDArray[np.float64], g: NDArray[np.intp], t: NDArray[np.intp]) -> None:
        denominator = sim.sum(0)[None, :] + sim.sum(1)[:, None] - sim
        share = np.divide(sim, denominator, out=np.zeros_like(sim), where=denominator > _EPS)
        some = share != 0.0  # adding 0 changes no sum
        self._pending.append((self._keys(g, t)[some], share[some]))
        self._pending_entries += int(some.sum())
        if self._pending_entries >= self.MERGE_ENTRIES:
            self._merge()
        self.gt_count[g] += 1
        self.track_count[t] += 1

    def aligned(self) -> None:
        self._merge()
        gt_count, track_count, n, value = self.gt_count, self.track_count, self.n_track, self.potential
        self.alignment = value / np.maximum(gt_count[self.keys // n] + track_count[self.keys % n] - value, _EPS)

    def match(self, sim: NDArray[np.float64], g: NDArray[np.intp], t: NDArray[np.intp]) -> None:
        keys = self._keys(g, t)
        at = np.searchsorted(self.keys, keys)
        met = at < len(self.keys)
        met[met] = self.keys[at[met]] == keys[met]
        alignment = np.zeros(keys.shape)
        alignment[met] = self.alignment[at[met]]
        rows, cols = linear_sum_assignment(-(alignment * sim))
        matched = sim[rows, cols]
        ok = matched[None, :] >= ALPHAS[:, None] - _EPS  # (alphas, matched pairs)
        hits = ok.sum(axis=1)
        self.tp += hits
        self.fn += len(g) - hits
        self.fp += len(t) - hits
        self.loc += np.where(ok, matched[None, :], 0.0).sum(axis=1)
        for key, column in zip(keys[rows, cols].tolist(), ok.T):
            if column.any():
                self.matches[key] = self.matches.get(key, 0.0) + column

    def counts(self) -> _Counts:
        association = np.zeros(len(ALPHAS))
        for key, matches in self.matches.items():
            union = self.gt_count[key // self.n_track] + self.track_count[key % self.n_track] - matches
            association += matches * (matches / np.maximum(1, union))
        return _Counts(self.tp, self.fn, self.fp, association, self.loc)


def hota(ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip], similarity: Similarity = iou_3d) -> Hota:
    """HOTA and its parts over clips of ground truth and tracker output, frame for frame."""
    if len(ground_truth) != len(tracks) or any(len(g) != len(t) for g, t in zip(ground_truth, tracks)):
        raise ValueError("ground truth and tracks differ in number of clips or frames")
    return combined([_clip_counts(g, t, similarity) for g, t in zip(ground_truth, tracks)])


def combined(counts: Sequence[_Counts]) -> Hota:
    """HOTA of clips from their counts, as TrackEval combines sequences."""
    tp, fn, fp = (sum(getattr(c, name) for c in counts) for name in ("tp", "fn", "fp"))
    assa = sum(c.association for c in counts) / np.maximum(1, tp)
    loca = np.maximum(1e-10, sum(c.similarity for c in counts)) / np.maximum(1e-10, tp)
    deta = tp / np.maximum(1, tp + fn + fp)
    per_alpha = np.sqrt(deta * assa)
    return Hota(float(per_alpha.mean()), float(deta.mean()), float(assa.mean()), float(loca.mean()), per_alpha)


def centre_hota(ground_truth: Sequence[Clip], tracks: Sequence[TrackedClip]) -> Hota:
    """HOTA on the pitch plane: centre distance with GS-HOTA's 5 m Gaussian tolerance, no box shape."""
    return hota(ground_truth, tracks, centre_similarity)
