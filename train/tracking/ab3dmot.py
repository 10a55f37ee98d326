"""AB3DMOT (Weng et al., 2020) as the paper's baseline, on the tracklets' boxes at t only.

Each frame: every track's constant-velocity Kalman filter predicts; the 3D IoU of detections and
predictions is matched by the Hungarian algorithm, pairs under ``association.lower_bound`` (AB3DMOT's
0.01) left unmatched; matched filters measure their detection, unmatched detections start tracks. A
track is output (its filtered box, the mean score of its matched detections) once it has
``life_cycle.min_hits`` (3) hits; any track dies after ``max_misses`` + 1 (AB3DMOT's max_age, 2)
consecutive misses, a tentative one too (the config's ``tentative_max_misses`` equals
``max_misses``). As in AB3DMOT's code, every track is output during the first ``min_hits`` frames
of a clip, and hits count all matched frames. The config is train/configs/tracking/1_ab3dmot.yaml.
"""

from __future__ import annotations

import numpy as np

from train.geometry import iou_3d
from train.tracking import life_cycle, motion_model
from train.tracking.association import match
from train.tracking.config import TrackerConfig
from train.tracking.motion_model import MOTION_MODELS
from train.tracking.track_table import append, end_frame, new_tracks
from train.tracking.types import TrackedFrame, Tracklets


class Ab3dmot:
    """Online: feed one frame's tracklets at a time to ``step``; only their boxes at t are used.
    ``config.association.method`` is ``iou_3d``."""

    def __init__(self, config: TrackerConfig) -> None:
        self.config = config
        self.kalman = MOTION_MODELS[config.motion_model]
        self._tracks = new_tracks(np.empty((0, 1, 7)), np.empty(0), 0, self.kalman)
        self._next_id = 0
        self._frames = 0

    def step(self, tracklets: Tracklets) -> TrackedFrame:
        life, tracks = self.config.life_cycle, self._tracks
        detections, scores = tracklets.boxes[:, 2], tracklets.scores
        self._frames += 1
        predicted = motion_model.predict(tracks.kalman, self.kalman)
        iou = iou_3d(detections, motion_model.state_boxes(predicted))
        rows, cols = match(iou, self.config.association.lower_bound)
        k = len(tracks.ids)
        matched = np.zeros(k, dtype=bool)
        matched[cols] = True
        measured = np.zeros((k, 1, 7))
        measured[cols, 0] = detections[rows]
        matched_scores = np.zeros(k)
        matched_scores[cols] = scores[rows]
        tracks = end_frame(tracks, predicted, matched, measured, matched_scores, self.kalman, life)
        born = np.setdiff1d(np.arange(len(detections)), rows)
        tracks = append(tracks, new_tracks(detections[born, None], scores[born], self._next_id, self.kalman))
        self._next_id += len(born)
        self._tracks = tracks
        shown = life_cycle.confirmed(tracks.hits, life) | (self._frames <= life.min_hits)
        return TrackedFrame(motion_model.state_boxes(tracks.kalman)[shown], tracks.ids[shown], tracks.scores[shown])
