"""Pitch zones: the paper's detection box and the rest of the pitch, to score a whole-pitch rig where the paper's
rig looks and where it does not.

A box is in a zone by its centre: `paper box` is simgen.coverage's `paper` area, [-40, 40] m in x and y of the pitch
frame (the paper's detection range); `outside` is everything else.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from simgen.coverage.summary import in_area
from train.tracking.types import GroundTruthFrame, TrackedFrame

ZONES = ("paper box", "outside")


def zone_index(boxes: NDArray) -> NDArray[np.int64]:
    """(N,) index into ZONES of each box (N, 7) by its centre."""
    centres = np.asarray(boxes, np.float64).reshape(-1, 7)[:, :2]
    return np.where(in_area(centres, "paper"), 0, 1).astype(np.int64)


def truth_in_zone(clip: Sequence[GroundTruthFrame], zone: int) -> list[GroundTruthFrame]:
    """A clip's labelled boxes whose centre is in ZONES[zone], frame by frame."""
    return [GroundTruthFrame(f.boxes[keep], f.ids[keep]) for f in clip for keep in [zone_index(f.boxes) == zone]]


def tracks_in_zone(clip: Sequence[TrackedFrame], zone: int) -> list[TrackedFrame]:
    """A tracker's boxes whose centre is in ZONES[zone], frame by frame (its backfill merged already, as
    train.tracking.clip.track_clip gives them)."""
    return [TrackedFrame(f.boxes[keep], f.ids[keep], f.scores[keep], (), None if f.states is None else f.states[keep])
            for f in clip for keep in [zone_index(f.boxes) == zone]]
