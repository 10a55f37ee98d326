"""AB3DMOT (Weng et al., 2020) as the paper's baseline, on the tracklets' boxes at t only.

Each frame: every track's constant-velocity Kalman filter predicts; the 3D IoU of detections and
predictions is matched by the Hungarian algorithm, pairs under ``iou_threshold`` (0.01) left
unmatched; matched filters measure their detection, unmatched detections start tracks. A track is
output (its filtered box, the mean score of its matched detections) once it has 3 hits, and while it has missed fewer
than ``max_age`` (2) consecutive frames; at 2 misses it dies. As in AB3DMOT's code, every track is
output during the first ``min_hits`` frames of a clip, and hits count all matched frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from train.geometry import iou_3d
from train.tracking import life_cycle, motion_model
from train.tracking.association import match
from train.tracking.life_cycle import LifeCycleConfig
from train.tracking.motion_model import KalmanConfig
from train.tracking.track_table import append, end_frame, new_tracks
from train.tracking.types import TrackedFrame, Tracklets


@dataclass(frozen=True)
class Ab3dmotConfig:
    iou_threshold: float = 0.01
    min_hits: int = 3
    max_age: int = 2
    kalman: KalmanConfig = field(default_factory=KalmanConfig)


class Ab3dmot:
    """Online: feed one frame's tracklets at a time to ``step``; only their boxes at t are used."""

    def __init__(self, config: Ab3dmotConfig | None = None) -> None:
        self.config = config or Ab3dmotConfig()
        lives = self.config.max_age - 1
        self._rules = LifeCycleConfig(self.config.min_hits, max_misses=lives, tentative_max_misses=lives)
        self._tracks = new_tracks(np.empty((0, 1, 7)), np.empty(0), 0, self.config.kalman)
        self._next_id = 0
        self._frames = 0

    def step(self, tracklets: Tracklets) -> TrackedFrame:
        cfg, tracks = self.config, self._tracks
        detections, scores = tracklets.boxes[:, 2], tracklets.scores
        self._frames += 1
        predicted = motion_model.predict(tracks.kalman, cfg.kalman)
        rows, cols = match(iou_3d(detections, motion_model.state_boxes(predicted)), cfg.iou_threshold)
        k = len(tracks.ids)
        matched = np.zeros(k, dtype=bool)
        matched[cols] = True
        measured = np.zeros((k, 1, 7))
        measured[cols, 0] = detections[rows]
        matched_scores = np.zeros(k)
        matched_scores[cols] = scores[rows]
        tracks = end_frame(tracks, predicted, matched, measured, matched_scores, cfg.kalman, self._rules)
        born = np.setdiff1d(np.arange(len(detections)), rows)
        tracks = append(tracks, new_tracks(detections[born, None], scores[born], self._next_id, cfg.kalman))
        self._next_id += len(born)
        self._tracks = tracks
        shown = life_cycle.confirmed(tracks.hits, self._rules) | (self._frames <= cfg.min_hits)
        return TrackedFrame(motion_model.state_boxes(tracks.kalman)[shown], tracks.ids[shown], tracks.scores[shown])
