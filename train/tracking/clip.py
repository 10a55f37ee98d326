"""A whole clip through an online tracker, with the boxes it back-fills merged into earlier frames; the tracker
a config names (`make_tracker`)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol

import numpy as np

from train.tracking.config import TrackerConfig
from train.tracking.tracker import Tracker
from train.tracking.types import TrackedFrame, Tracklets


class OnlineTracker(Protocol):
    def step(self, tracklets: Tracklets) -> TrackedFrame: ...


def make_tracker(config: TrackerConfig) -> OnlineTracker:
    """A fresh tracker (one per clip) run by the config: AB3DMOT's or the paper's."""
    return Tracker(config)


def merge(frame: TrackedFrame, more: TrackedFrame) -> TrackedFrame:
    """One frame's output and more boxes for it (of other tracks)."""
    return TrackedFrame(
        np.concatenate([frame.boxes, more.boxes]),
        np.concatenate([frame.ids, more.ids]),
        np.concatenate([frame.scores, more.scores]),
    )


def track_clip(tracker: OnlineTracker, frames: Iterable[Tracklets]) -> list[TrackedFrame]:
    """One output per frame of tracklets; a frame's back-filled boxes go to the frames before it."""
    out: list[TrackedFrame] = []
    for tracklets in frames:
        frame = tracker.step(tracklets)
        for back, earlier in enumerate(reversed(frame.backfill), start=1):
            if back <= len(out):
                out[-back] = merge(out[-back], earlier)
        out.append(TrackedFrame(frame.boxes, frame.ids, frame.scores))
    return out
