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

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from train.tracking import life_cycle, motion_model, split
from train.tracking.association import diou_affinity, match
from train.tracking.life_cycle import LifeCycleConfig
from train.tracking.motion_model import PLAYER_KALMAN, KalmanConfig
from train.tracking.split import SplitConfig
from train.tracking.track_table import append, end_frame, new_tracks
from train.tracking.types import TrackedFrame, Tracklets

_OVERLAP = slice(0, 2)  # a tracklet's boxes at t-2 and t-1


@dataclass(frozen=True)
class DiouTrackerConfig:
    """The paper's values (Sect. 4.1) where it gives them."""

    # Weights of the DIoU at t-2 and at t-1. The paper does not give them; t-1 weighs more because
    # both its boxes come from later, better-supported regressions (the trajectory's box at t-1
    # was regressed as a tracklet's current box). They sum to 1, so the bounds keep DIoU's scale.
    weights: tuple[float, float] = (0.4, 0.6)
    normal_lower_bound: float = -0.125
    dying_lower_bound: float = -0.5
    max_dying_frames: int = 6
    min_hits: int = 3
    birth_death: bool = True
    split: bool = True
    output_dying: bool = True
    backfill: bool = True
    split_config: SplitConfig = field(default_factory=SplitConfig)
    kalman: KalmanConfig = PLAYER_KALMAN

    def life_cycle(self) -> LifeCycleConfig:
        if self.birth_death:
            return LifeCycleConfig(self.min_hits, self.max_dying_frames, tentative_max_misses=0)
        return LifeCycleConfig(min_hits=1, max_misses=0, tentative_max_misses=0)


class DiouTracker:
    """Online: feed one frame's tracklets at a time to ``step``."""

    def __init__(self, config: DiouTrackerConfig | None = None) -> None:
        self.config = config or DiouTrackerConfig()
        self._rules = self.config.life_cycle()
        self._tracks = new_tracks(np.empty((0, 2, 7)), np.empty(0), 0, self.config.kalman)
        self._next_id = 0
        self._fused: set[frozenset[int]] = set()  # ids of the pairs split at t-1

    def step(self, tracklets: Tracklets) -> TrackedFrame:
        cfg, tracks = self.config, self._tracks
        boxes, scores = tracklets.boxes, tracklets.scores
        predicted = motion_model.predict(tracks.kalman, cfg.kalman)
        confirmed = life_cycle.confirmed(tracks.hits, self._rules)
        loosest = np.where(confirmed & cfg.birth_death, cfg.dying_lower_bound, cfg.normal_lower_bound)
        affinity = diou_affinity(boxes[:, _OVERLAP], tracks.boxes, cfg.weights, loosest)  # (N, K)
        source = np.full(len(tracks.ids), -1)  # each trajectory's tracklet; -1: none yet
        used = np.zeros(len(boxes), dtype=bool)

        def associate(trajectories: NDArray[np.intp], lower_bound: float) -> None:
            free = np.flatnonzero(~used)
            rows, cols = match(affinity[np.ix_(free, trajectories)], lower_bound)
            source[trajectories[cols]] = free[rows]
            used[free[rows]] = True

        associate(np.flatnonzero(confirmed & (tracks.misses == 0)), cfg.normal_lower_bound)
        if cfg.birth_death:
            associate(np.flatnonzero(confirmed & (source < 0)), cfg.dying_lower_bound)
        associate(np.flatnonzero(~confirmed), cfg.normal_lower_bound)
        matched = source >= 0
        measured = np.zeros((len(tracks.ids), 2, 7))
        measured[matched] = boxes[source[matched], 1:]
        matched_scores = np.zeros(len(tracks.ids))
        matched_scores[matched] = scores[source[matched]]
        if cfg.split:
            pair, pair_boxes, pair_source = self._split(tracklets, predicted, source)
            measured[pair], matched_scores[pair], matched[pair] = pair_boxes, scores[pair_source], True

        backfill = self._backfill(tracklets, source, matched & ~confirmed, matched_scores) if cfg.backfill else ()
        tracks = end_frame(tracks, predicted, matched, measured, matched_scores, cfg.kalman, self._rules)
        born = np.flatnonzero(~used)
        tracks = append(tracks, new_tracks(boxes[born, 1:], scores[born], self._next_id, cfg.kalman))
        self._next_id += len(born)
        self._tracks = tracks
        shown = life_cycle.confirmed(tracks.hits, self._rules)
        if not cfg.output_dying:
            shown &= tracks.misses == 0
        return TrackedFrame(tracks.boxes[shown, -1], tracks.ids[shown], tracks.scores[shown], backfill)

    def _backfill(
        self, tracklets: Tracklets, source: NDArray[np.intp], tentative: NDArray[np.bool_], scores: NDArray[np.float64]
    ) -> tuple[TrackedFrame, ...]:
        """Frames t-n..t-1 (n = min(min_hits - 1, 2)) of the trajectories this frame confirms, from the
        boxes of the tracklet that confirms them, scored with their mean score."""
        tracks, need = self._tracks, self._rules.min_hits
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
        tracks, config = self._tracks, self.config.split_config
        confirmed = life_cycle.confirmed(tracks.hits, self._rules)
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
