"""The one tracker: the paper's 3D DIoU tracker (Sect. 3.2) and AB3DMOT (Weng et al., 2020) are configs of it.

Per frame t every track's constant-velocity Kalman filter predicts, then the association
(``association.method``) scores tracklets against tracks: ``tracklet_diou``, the paper's weighted sum of
the DIoU of a tracklet's boxes at t-2, t-1 and a track's (a track keeps two boxes); ``iou_3d``,
AB3DMOT's 3D IoU of the tracklets' boxes at t and the predictions (a track keeps one box). Hungarian
matching, pairs under the lower bound left unmatched, either at once over all tracks (AB3DMOT) or, with
``association.cascade``, in turn for:

1. Normal tracks (confirmed, matched at t-1), at ``lower_bound``.
2. With birth and death, dying tracks (confirmed, unmatched for up to ``max_misses`` frames and carried
   by the Kalman filter) and the normal ones left by 1, against the tracklets left, at
   ``dying_lower_bound``. A match makes them normal again.
3. New tracks (not yet confirmed), at ``lower_bound``, against the tracklets left: after the confirmed
   ones, so that a duplicate detection's new track cannot take a player from his own (dying) track.
4. With ``split``, a matched tracklet that fuses its track with an unmatched neighbour gives both a
   box (train.tracking.split).

Unmatched tracklets start tracks. Birth and death (train.tracking.life_cycle) decide which are output
and which die; with ``backfill`` a newly confirmed track's first two frames are output too
(``TrackedFrame.backfill``): the confirming tracklet's boxes at t-2 and t-1; with ``warm_up`` every
track is output during a clip's first ``min_hits`` frames (AB3DMOT's code). A matched track takes the
tracklet's boxes as its own and outputs, by ``output``, the tracklet's box at t or the Kalman filter's
updated box (AB3DMOT); an unmatched one its predicted box. A track's score is the mean of its matched
tracklets' scores.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
from numpy.typing import NDArray

from train.geometry import iou_3d
from train.tracking import life_cycle, motion_model, split
from train.tracking.association import diou_affinity, match
from train.tracking.config import TrackerConfig
from train.tracking.motion_model import MOTION_MODELS
from train.tracking.split import SplitConfig
from train.tracking.track_table import TrackTable, append, end_frame, new_tracks
from train.tracking.types import CONFIRMED, DYING, TENTATIVE, TrackedFrame, Tracklets

_OVERLAP = slice(0, 2)  # a tracklet's boxes at t-2 and t-1
_KEPT_BOXES = {"tracklet_diou": 2, "iou_3d": 1}  # a track's last boxes (t-1 and t; t), as the association needs


class Tracker:
    """Online: feed one frame's tracklets at a time to ``step``; its behaviour is its config's."""

    def __init__(self, config: TrackerConfig) -> None:
        self.config = config
        self.kalman = MOTION_MODELS[config.motion_model]
        self._kept = _KEPT_BOXES[config.association.method]
        self._split_rules = SplitConfig()
        self._tracks = new_tracks(np.empty((0, self._kept, 7)), np.empty(0), 0, self.kalman)
        self._next_id = 0
        self._frames = 0
        self._fused: set[frozenset[int]] = set()  # ids of the pairs split at t-1

    @property
    def tracks(self) -> TrackTable:
        """The live tracks after the last step, tentative and dying ones included (read, do not change)."""
        return self._tracks

    @property
    def split_pairs(self) -> frozenset[frozenset[int]]:
        """Ids of the track pairs the split module gave two boxes in the last step."""
        return frozenset(self._fused)

    def state(self) -> dict[str, NDArray]:
        """Everything a step reads, as plain arrays (a resumed run's `restore`)."""
        tracks = self._tracks
        fused = np.array(sorted(sorted(pair) for pair in self._fused), np.int64).reshape(-1, 2)
        return {**{f"tracks_{f.name}": getattr(tracks, f.name) for f in fields(tracks)},
                "next_id": np.array(self._next_id), "frames": np.array(self._frames), "fused": fused}

    def restore(self, state: dict[str, NDArray]) -> None:
        """Back to a `state` of a tracker of the same config."""
        self._tracks = TrackTable(**{f.name: state[f"tracks_{f.name}"] for f in fields(TrackTable)})
        self._next_id, self._frames = int(state["next_id"]), int(state["frames"])
        self._fused = {frozenset(pair) for pair in state["fused"].tolist()}

    def step(self, tracklets: Tracklets) -> TrackedFrame:
        cfg, life, tracks = self.config.association, self.config.life_cycle, self._tracks
        boxes, scores = tracklets.boxes, tracklets.scores
        self._frames += 1
        predicted = motion_model.predict(tracks.kalman, self.kalman)
        confirmed = life_cycle.confirmed(tracks.hits, life)
        dying_stage = cfg.cascade and life.birth_death
        if cfg.method == "iou_3d":
            affinity = iou_3d(boxes[:, -1], motion_model.state_boxes(predicted))  # (N, K)
        else:
            loosest = np.where(confirmed & dying_stage, cfg.dying_lower_bound, cfg.lower_bound)
            affinity = diou_affinity(boxes[:, _OVERLAP], tracks.boxes, cfg.weights, loosest)
        source = np.full(len(tracks.ids), -1)  # each track's tracklet; -1: none yet
        used = np.zeros(len(boxes), dtype=bool)

        def associate(trajectories: NDArray[np.intp], lower_bound: float) -> None:
            free = (~used).nonzero()[0]
            if not len(free) or not len(trajectories):
                return
            rows, cols = match(affinity[free[:, None], trajectories], lower_bound)
            source[trajectories[cols]] = free[rows]
            used[free[rows]] = True

        if cfg.cascade:
            associate((confirmed & (tracks.misses == 0)).nonzero()[0], cfg.lower_bound)
            if dying_stage:
                associate((confirmed & (source < 0)).nonzero()[0], cfg.dying_lower_bound)
            associate((~confirmed).nonzero()[0], cfg.lower_bound)
        else:
            associate(np.arange(len(tracks.ids)), cfg.lower_bound)
        matched = source >= 0
        measured = np.zeros((len(tracks.ids), self._kept, 7))
        measured[matched] = boxes[source[matched], -self._kept :]
        matched_scores = np.zeros(len(tracks.ids))
        matched_scores[matched] = scores[source[matched]]
        if self.config.split:
            pair, pair_boxes, pair_source = self._split(tracklets, predicted, source)
            measured[pair], matched_scores[pair], matched[pair] = pair_boxes, scores[pair_source], True

        backfill = self._backfill(tracklets, source, matched & ~confirmed, matched_scores) if life.backfill else ()
        tracks = end_frame(tracks, predicted, matched, measured, matched_scores, self.kalman, life)
        born = (~used).nonzero()[0]
        if len(born):
            tracks = append(tracks, new_tracks(boxes[born, -self._kept :], scores[born], self._next_id, self.kalman))
            self._next_id += len(born)
        self._tracks = tracks
        confirmed_now = life_cycle.confirmed(tracks.hits, life)
        shown = confirmed_now | (life.warm_up and self._frames <= life.min_hits)
        if not life.output_dying:
            shown &= tracks.misses == 0
        out = motion_model.state_boxes(tracks.kalman) if self.config.output == "kalman" else tracks.boxes[:, -1]
        state = np.where(confirmed_now, np.where(tracks.misses > 0, DYING, CONFIRMED), TENTATIVE)
        return TrackedFrame(out[shown], tracks.ids[shown], tracks.scores[shown], backfill, state[shown])

    def _backfill(
        self, tracklets: Tracklets, source: NDArray[np.intp], tentative: NDArray[np.bool_], scores: NDArray[np.float64]
    ) -> tuple[TrackedFrame, ...]:
        """Frames t-n..t-1 (n = min(min_hits - 1, 2)) of the trajectories this frame confirms, from the
        boxes of the tracklet that confirms them, scored with their mean score."""
        tracks, need = self._tracks, life_cycle.hits_to_confirm(self.config.life_cycle)
        newly = (tentative & (tracks.hits + 1 >= need)).nonzero()[0]
        frames = min(need - 1, _OVERLAP.stop)
        if not len(newly) or frames < 1:
            return ()
        boxes = tracklets.boxes[source[newly], _OVERLAP.stop - frames : _OVERLAP.stop]  # (F, n, 7)
        mean = (tracks.score_sum[newly] + scores[newly]) / (tracks.hits[newly] + 1)
        confirmed = np.full(len(newly), CONFIRMED)
        return tuple(TrackedFrame(boxes[:, k], tracks.ids[newly], mean, (), confirmed) for k in range(frames))

    def _split(
        self, tracklets: Tracklets, predicted: motion_model.KalmanState, source: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.intp]]:
        """Trajectories (F,), their boxes at t-1 and t (F, 2, 7) and tracklets (F,) for the matched
        tracklets (``source``: per trajectory) that fuse their trajectory and an unmatched one, both
        confirmed (a new trajectory may be a duplicate): both trajectories of each such pair."""
        tracks, config = self._tracks, self._split_rules
        confirmed = life_cycle.confirmed(tracks.hits, self.config.life_cycle)
        partners = ((source >= 0) & confirmed).nonzero()[0]
        orphans = ((source < 0) & confirmed).nonzero()[0]
        previous = tracks.boxes[:, 1]
        offset = previous[partners, None, :2] - previous[None, orphans, :2]  # (P, O, 2)
        near = np.sqrt(offset[..., 0] ** 2 + offset[..., 1] ** 2) <= config.max_pair_gap_m
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
