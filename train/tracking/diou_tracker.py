"""The paper's 3D DIoU tracker (Sect. 3.2): tracklets linked to trajectories on overlapping frames.

The affinity of a tracklet (boxes at t-2, t-1, t) and a trajectory (its boxes at t-2 and t-1) is
the weighted sum of their DIoU at t-2 and at t-1. Per frame t, Hungarian matching in turn for:

1. Normal trajectories (confirmed, matched at t-1), lower bound -0.125.
2. Dying trajectories (confirmed, unmatched at t-1 for up to 6 frames and carried by the Kalman
   filter) and the normal ones left unmatched by 1, against the tracklets left: lower bound -0.5.
   A match makes them normal again.
3. New trajectories (not yet confirmed), lower bound -0.125, against the tracklets left. They are
   matched after the confirmed ones, so that a duplicate detection's new trajectory cannot take a
   player from his own (dying) trajectory.
4. Split: a matched tracklet that fuses its trajectory with an unmatched neighbour gives both a
   box (train.tracking.split).

Tracklets still unmatched start new trajectories, output once matched in 3 consecutive frames and
dropped at their first miss; a confirmed trajectory dies after 6 unmatched frames. When a
trajectory is confirmed, its first two frames are output too (``backfill``, in
``TrackedFrame.backfill``): the confirming tracklet's boxes at t-2 and t-1. A matched trajectory
takes the tracklet's boxes at t-1 and t as its own (a dying one thus gets real boxes for the last
frame it was carried through) and outputs the box at t; dying trajectories output their predicted
box (``output_dying``). A trajectory's score is the mean of its matched tracklets' scores.

With ``birth_death`` off, every tracklet is output from its first frame and an unmatched trajectory
ends at once (no step 2); with ``split`` off, step 4 is skipped: the paper's ablation.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from train.tracking import life_cycle, motion_model, split
from train.tracking.association import diou_affinity, match
from train.tracking.config import TrackerConfig
from train.tracking.motion_model import MOTION_MODELS
from train.tracking.split import SplitConfig
from train.tracking.track_table import append, end_frame, new_tracks
from train.tracking.types import TrackedFrame, Tracklets

_OVERLAP = slice(0, 2)  # a tracklet's boxes at t-2 and t-1


class DiouTracker:
    """Online: feed one frame's tracklets at a time to ``step``; ``config.association.method`` is
    ``tracklet_diou``."""

    def __init__(self, config: TrackerConfig) -> None:
        self.config = config
        self.kalman = MOTION_MODELS[config.motion_model]
        self._split_rules = SplitConfig()
        self._tracks = new_tracks(np.empty((0, 2, 7)), np.empty(0), 0, self.kalman)
        self._next_id = 0
        self._fused: set[frozenset[int]] = set()  # ids of the pairs split at t-1

    def step(self, tracklets: Tracklets) -> TrackedFrame:
        cfg, life, tracks = self.config.association, self.config.life_cycle, self._tracks
        boxes, scores = tracklets.boxes, tracklets.scores
        predicted = motion_model.predict(tracks.kalman, self.kalman)
        confirmed = life_cycle.confirmed(tracks.hits, life)
        loosest = np.where(confirmed & life.birth_death, cfg.dying_lower_bound, cfg.lower_bound)
        affinity = diou_affinity(boxes[:, _OVERLAP], tracks.boxes, cfg.weights, loosest)  # (N, K)
        source = np.full(len(tracks.ids), -1)  # each trajectory's tracklet; -1: none yet
        used = np.zeros(len(boxes), dtype=bool)

        def associate(trajectories: NDArray[np.intp], lower_bound: float) -> None:
            free = np.flatnonzero(~used)
            rows, cols = match(affinity[np.ix_(free, trajectories)], lower_bound)
            source[trajectories[cols]] = free[rows]
            used[free[rows]] = True

        associate(np.flatnonzero(confirmed & (tracks.misses == 0)), cfg.lower_bound)
        if life.birth_death:
            associate(np.flatnonzero(confirmed & (source < 0)), cfg.dying_lower_bound)
        associate(np.flatnonzero(~confirmed), cfg.lower_bound)
        matched = source >= 0
        measured = np.zeros((len(tracks.ids), 2, 7))
        measured[matched] = boxes[source[matched], 1:]
        matched_scores = np.zeros(len(tracks.ids))
        matched_scores[matched] = scores[source[matched]]
        if self.config.split:
            pair, pair_boxes, pair_source = self._split(tracklets, predicted, source)
            measured[pair], matched_scores[pair], matched[pair] = pair_boxes, scores[pair_source], True

        backfill = self._backfill(tracklets, source, matched & ~confirmed, matched_scores) if life.backfill else ()
        tracks = end_frame(tracks, predicted, matched, measured, matched_scores, self.kalman, life)
        born = np.flatnonzero(~used)
        tracks = append(tracks, new_tracks(boxes[born, 1:], scores[born], self._next_id, self.kalman))
        self._next_id += len(born)
        self._tracks = tracks
        shown = life_cycle.confirmed(tracks.hits, life)
        if not life.output_dying:
            shown &= tracks.misses == 0
        return TrackedFrame(tracks.boxes[shown, -1], tracks.ids[shown], tracks.scores[shown], backfill)

    def _backfill(
        self, tracklets: Tracklets, source: NDArray[np.intp], tentative: NDArray[np.bool_], scores: NDArray[np.float64]
    ) -> tuple[TrackedFrame, ...]:
        """Frames t-n..t-1 (n = min(min_hits - 1, 2)) of the trajectories this frame confirms, from the
        boxes of the tracklet that confirms them, scored with their mean score."""
        tracks, need = self._tracks, life_cycle.hits_to_confirm(self.config.life_cycle)
        newly = np.flatnonzero(tentative & (tracks.hits + 1 >= need))
        frames = min(need - 1, _OVERLAP.stop)
        if not len(newly) or frames < 1:
            return ()
        boxes = tracklets.boxes[source[newly], _OVERLAP.stop - frames : _OVERLAP.stop]  # (F, n, 7)
        mean = (tracks.score_sum[newly] + scores[newly]) / (tracks.hits[newly] + 1)
        return tuple(TrackedFrame(boxes[:, k], tracks.ids[newly], mean) for k in range(frames))

    def _split(
        self, tracklets: Tracklets, predicted: motion_model.KalmanState, source: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.intp]]:
        """Trajectories (F,), their boxes at t-1 and t (F, 2, 7) and tracklets (F,) for the matched
        tracklets (``source``: per trajectory) that fuse their trajectory and an unmatched one, both
        confirmed (a new trajectory may be a duplicate): both trajectories of each such pair."""
        tracks, config = self._tracks, self._split_rules
        confirmed = life_cycle.confirmed(tracks.hits, self.config.life_cycle)
        partners = np.flatnonzero((source >= 0) & confirmed)
        orphans = np.flatnonzero((source < 0) & confirmed)
        previous = tracks.boxes[:, 1]
        gap = np.linalg.norm(previous[partners, None, :2] - previous[None, orphans, :2], axis=-1)
        near = gap <= config.max_pair_gap_m
        if not near.any():
            self._fused = set()
            return np.empty(0, dtype=np.intp), np.empty((0, 2, 7)), np.empty(0, dtype=np.intp)
        partners, orphans = partners[near.any(axis=1)], orphans[near.any(axis=0)]
        still_fused = np.zeros((len(partners), len(orphans)), dtype=bool)
        for a, b in map(tuple, self._fused):
            still_fused |= np.outer(tracks.ids[partners] == a, tracks.ids[orphans] == b)
            still_fused |= np.outer(tracks.ids[partners] == b, tracks.ids[orphans] == a)
        fused, lone = split.find_fusions(
            tracklets.boxes[source[partners], 1],
            previous[partners],
            previous[orphans],
            tracks.misses[orphans] == 0,
            still_fused,
            config,
        )
        both = np.stack([partners[fused], orphans[lone]], axis=1)  # (F, 2)
        self._fused = {frozenset(pair) for pair in tracks.ids[both].tolist()}
        rows = source[both[:, 0]]
        predicted_boxes = motion_model.state_boxes(predicted)[both]
        split_t = split.split_boxes(tracklets.boxes[rows, 2], previous[both], predicted_boxes, config)
        pair = both.T.ravel()
        boxes = np.stack([previous[pair], split_t.transpose(1, 0, 2).reshape(-1, 7)], axis=1)
        return pair, boxes, np.tile(rows, 2)
