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
    """One frame's output and more boxes for it (of other tracks); states where both have them."""
    states = None if frame.states is None or more.states is None else np.concatenate([frame.states, more.states])
    return TrackedFrame(
        np.concatenate([frame.boxes, more.boxes]),
        np.concatenate([frame.ids, more.ids]),
        np.concatenate([frame.scores, more.scores]),
        (),
        states,
    )


BACKFILL_FRAMES = 2  # a tracker back-fills at most the two frames before the one it confirms a track in


class HeldFrames:
    """A tracker's outputs held back BACKFILL_FRAMES frames, so that the boxes later frames back-fill into them
    are merged in before they are final; each output travels with a key of the caller's (its frame)."""

    def __init__(self) -> None:
        self.frames: list[tuple[object, TrackedFrame]] = []

    def push(self, key: object, frame: TrackedFrame) -> list[tuple[object, TrackedFrame]]:
        """Take one frame's output; return the frames now final, oldest first."""
        for back, earlier in enumerate(reversed(frame.backfill), start=1):
            if back <= len(self.frames):
                self.frames[-back] = (self.frames[-back][0], merge(self.frames[-back][1], earlier))
        self.frames.append((key, TrackedFrame(frame.boxes, frame.ids, frame.scores, (), frame.states)))
        done, self.frames = self.frames[:-BACKFILL_FRAMES], self.frames[-BACKFILL_FRAMES:]
        return done

    def flush(self) -> list[tuple[object, TrackedFrame]]:
        """The frames still held (the clip ended), oldest first."""
        done, self.frames = self.frames, []
        return done


def track_clip(tracker: OnlineTracker, frames: Iterable[Tracklets]) -> list[TrackedFrame]:
    """One output per frame of tracklets; a frame's back-filled boxes go to the frames before it."""
    held, out = HeldFrames(), []
    for tracklets in frames:
        out += [frame for _, frame in held.push(None, tracker.step(tracklets))]
    return out + [frame for _, frame in held.flush()]
