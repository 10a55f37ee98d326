"""Live tracks as one table of per-track arrays: ids, recent boxes, Kalman state, life-cycle counts.

The tracker keeps its tracks here and changes them a frame at a time: predict every track,
write the boxes measured for the matched ones (the prediction for the others), count the frame,
drop the dead and append the newborn.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from train.tracking import life_cycle, motion_model
from train.tracking.life_cycle import LifeCycleConfig
from train.tracking.motion_model import KalmanConfig, KalmanState


@dataclass
class TrackTable:
    ids: NDArray[np.int64]  # (K,)
    boxes: NDArray[np.float64]  # (K, H, 7): the last H frames' boxes, oldest first
    mean: NDArray[np.float64]  # (K, 10) Kalman state
    covariance: NDArray[np.float64]  # (K, 10, 10)
    hits: NDArray[np.int64]  # (K,) matched frames
    misses: NDArray[np.int64]  # (K,) consecutive unmatched frames
    score_sum: NDArray[np.float64]  # (K,) summed scores of the matched detections

    @property
    def scores(self) -> NDArray[np.float64]:
        """(K,) a track's score: the mean of its matched detections' scores."""
        return self.score_sum / self.hits

    @property
    def kalman(self) -> KalmanState:
        return KalmanState(self.mean, self.covariance)


def new_tracks(
    boxes: NDArray[np.float64], scores: NDArray[np.float64], first_id: int, config: KalmanConfig
) -> TrackTable:
    """Tracks born from boxes (N, H, 7), the last of each the current one, with ids from first_id."""
    n = len(boxes)
    state = motion_model.init_state(boxes[:, -1], config)
    return TrackTable(
        ids=np.arange(first_id, first_id + n, dtype=np.int64),
        boxes=boxes.copy(),
        mean=state.mean,
        covariance=state.covariance,
        hits=np.ones(n, dtype=np.int64),
        misses=np.zeros(n, dtype=np.int64),
        score_sum=np.asarray(scores, np.float64).copy(),
    )


def end_frame(
    tracks: TrackTable,
    predicted: KalmanState,
    matched: NDArray[np.bool_],
    measured: NDArray[np.float64],
    scores: NDArray[np.float64],
    kalman: KalmanConfig,
    rules: LifeCycleConfig,
) -> TrackTable:
    """The tracks after a frame, then counted, the dead dropped.

    Matched tracks (mask) take their measured boxes (K, H, 7) as their recent boxes (a tracklet's
    past boxes replace the older ones) and their scores (K,); the Kalman filter measures the last
    box. The others add their predicted box. Matched scores add to the tracks' score sums.
    """
    hits, misses = life_cycle.count_frame(tracks.hits, tracks.misses, matched)
    keep = life_cycle.survives(hits, misses, rules).nonzero()[0]  # every matched track among them
    carried = np.concatenate([tracks.boxes[keep, 1:], motion_model.state_boxes(predicted)[keep, None]], axis=1)
    table = TrackTable(
        ids=tracks.ids[keep],
        boxes=carried,
        mean=predicted.mean[keep],
        covariance=predicted.covariance[keep],
        hits=hits[keep],
        misses=misses[keep],
        score_sum=(tracks.score_sum + np.where(matched, scores, 0.0))[keep],
    )
    rows = matched.nonzero()[0]
    if len(rows):
        updated = motion_model.update(
            KalmanState(predicted.mean[rows], predicted.covariance[rows]), measured[rows, -1], kalman
        )
        fresh = matched[keep]
        table.boxes[fresh] = measured[rows]
        table.mean[fresh], table.covariance[fresh] = updated.mean, updated.covariance
    return table


def append(tracks: TrackTable, newborn: TrackTable) -> TrackTable:
    if not len(newborn.ids):
        return tracks
    return TrackTable(
        **{f.name: np.concatenate([getattr(tracks, f.name), getattr(newborn, f.name)]) for f in fields(tracks)}
    )
