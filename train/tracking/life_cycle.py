"""Birth and death of tracks, from per-track counts of matched (hits) and missed frames.

A new track is tentative until it has been matched ``min_hits`` times; it is then confirmed and
output. A confirmed track survives ``max_misses`` consecutive missed frames (the paper's dying
trajectories, AB3DMOT's max_age - 1), a tentative one ``tentative_max_misses``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class LifeCycleConfig:
    min_hits: int
    max_misses: int
    tentative_max_misses: int


def count_frame(
    hits: NDArray[np.int64], misses: NDArray[np.int64], matched: NDArray[np.bool_]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Hits and consecutive misses after a frame in which the tracks ``matched`` were matched."""
    return hits + matched, np.where(matched, 0, misses + 1)


def confirmed(hits: NDArray[np.int64], config: LifeCycleConfig) -> NDArray[np.bool_]:
    """Tracks matched often enough to be output (hits never decrease, so this is for good)."""
    return hits >= config.min_hits


def survives(hits: NDArray[np.int64], misses: NDArray[np.int64], config: LifeCycleConfig) -> NDArray[np.bool_]:
    """Tracks that live on after a frame with these counts."""
    return misses <= np.where(confirmed(hits, config), config.max_misses, config.tentative_max_misses)
