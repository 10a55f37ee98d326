"""Birth and death of tracks, from per-track counts of matched (hits) and missed frames.

With ``birth_death``, a new track is tentative until it has been matched ``min_hits`` times; it is
then confirmed and output. A confirmed track survives ``max_misses`` consecutive missed frames (the
paper's dying trajectories, AB3DMOT's max_age - 1), a tentative one ``tentative_max_misses`` (the
paper: 0; AB3DMOT keeps it as long as a confirmed one). Without it, every track is confirmed at
once and ends at its first miss.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from simgen.validation import Strict

# A track lives at most this many frames unmatched or unconfirmed: 10 s at 10 Hz, 16 x the paper's
# 6 dying frames. With at most `train.config.MAX_DETECTIONS` (500) tracklets a frame, at most 500
# tracks are matched and 500 x 100 dying at once, so a frame's affinity matrix stays under 500 x
# 50,500 entries (200 MB).
MAX_TRACK_FRAMES = 100


class LifeCycleConfig(Strict):
    birth_death: bool  # off (tracklet_diou only): every tracklet output at once, a miss ends a track
    min_hits: int = Field(3, ge=1, le=MAX_TRACK_FRAMES)  # matches before a new track is output
    max_misses: int = Field(6, ge=0, le=MAX_TRACK_FRAMES)  # consecutive misses a confirmed track survives
    tentative_max_misses: int = Field(0, ge=0, le=MAX_TRACK_FRAMES)  # and a tentative one
    backfill: bool = False  # tracklet_diou: a confirmed track's first frames output from its tracklet
    output_dying: bool = True  # dying tracks output at their predicted box
    warm_up: bool = False  # every track output in a clip's first min_hits frames (AB3DMOT's code)


def hits_to_confirm(config: LifeCycleConfig) -> int:
    """Matched frames that confirm a track: ``min_hits``, or 1 without birth and death."""
    return config.min_hits if config.birth_death else 1


def count_frame(
    hits: NDArray[np.int64], misses: NDArray[np.int64], matched: NDArray[np.bool_]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Hits and consecutive misses after a frame in which the tracks ``matched`` were matched."""
    return hits + matched, np.where(matched, 0, misses + 1)


def confirmed(hits: NDArray[np.int64], config: LifeCycleConfig) -> NDArray[np.bool_]:
    """Tracks matched often enough to be output (hits never decrease, so this is for good)."""
    return hits >= hits_to_confirm(config)


def survives(hits: NDArray[np.int64], misses: NDArray[np.int64], config: LifeCycleConfig) -> NDArray[np.bool_]:
    """Tracks that live on after a frame with these counts."""
    if not config.birth_death:
        return misses == 0
    return misses <= np.where(confirmed(hits, config), config.max_misses, config.tentative_max_misses)
