"""What the trackers read and write and the metrics compare, one frame at a time.

Boxes follow train.geometry: ``(x, y, z, length, width, height, yaw)``, centre, metres and radians.
A clip is a sequence of frames at a fixed rate; track ids are unique within a clip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from train.geometry import BOX_DIM

TRACKLET_LEN = 3  # boxes at t-2, t-1 and t
STATES = ("tentative", "confirmed", "dying")  # a shown track's state, TrackedFrame.states indexes this
TENTATIVE, CONFIRMED, DYING = range(len(STATES))


def _array(value: ArrayLike, dtype: type, shape: tuple[int | None, ...], name: str) -> NDArray[Any]:
    arr = np.asarray(value, dtype=dtype)
    if arr.ndim != len(shape) or any(want not in (None, got) for want, got in zip(shape, arr.shape)):
        raise ValueError(f"{name} must have shape {shape} (None: any), got {arr.shape}")
    return arr


def _same_length(*arrays: NDArray[Any]) -> None:
    if len({len(a) for a in arrays}) > 1:
        raise ValueError(f"per-object arrays differ in length: {[len(a) for a in arrays]}")


@dataclass(frozen=True)
class Tracklets:
    """The detector's output for frame t: N short tracklets and their scores."""

    boxes: NDArray[np.float64]  # (N, 3, 7): [:, 0] at t-2, [:, 1] at t-1, [:, 2] at t
    scores: NDArray[np.float64]  # (N,) in [0, 1]

    def __post_init__(self) -> None:
        object.__setattr__(self, "boxes", _array(self.boxes, np.float64, (None, TRACKLET_LEN, BOX_DIM), "boxes"))
        object.__setattr__(self, "scores", _array(self.scores, np.float64, (None,), "scores"))
        _same_length(self.boxes, self.scores)


@dataclass(frozen=True)
class TrackedFrame:
    """A tracker's output for one frame: M boxes with their track ids and scores.

    ``backfill``: boxes for frames before this one (oldest first, the last one just before it) of
    tracks confirmed in this frame, at the frames they were not yet output (train.tracking.clip
    merges them into those frames). ``states``: each box's track's state (index into STATES), where
    the tracker says; None where it does not.
    """

    boxes: NDArray[np.float64]  # (M, 7)
    ids: NDArray[np.int64]  # (M,), unique in the frame
    scores: NDArray[np.float64]  # (M,)
    backfill: tuple[TrackedFrame, ...] = ()
    states: NDArray[np.int8] | None = None  # (M,)

    def __post_init__(self) -> None:
        object.__setattr__(self, "boxes", _array(self.boxes, np.float64, (None, BOX_DIM), "boxes"))
        object.__setattr__(self, "ids", _array(self.ids, np.int64, (None,), "ids"))
        object.__setattr__(self, "scores", _array(self.scores, np.float64, (None,), "scores"))
        _same_length(self.boxes, self.ids, self.scores)
        if self.states is not None:
            object.__setattr__(self, "states", _array(self.states, np.int8, (None,), "states"))
            _same_length(self.boxes, self.states)


@dataclass(frozen=True)
class GroundTruthFrame:
    """The labelled objects of one frame: G boxes with their track ids."""

    boxes: NDArray[np.float64]  # (G, 7)
    ids: NDArray[np.int64]  # (G,), unique in the frame

    def __post_init__(self) -> None:
        object.__setattr__(self, "boxes", _array(self.boxes, np.float64, (None, BOX_DIM), "boxes"))
        object.__setattr__(self, "ids", _array(self.ids, np.int64, (None,), "ids"))
        _same_length(self.boxes, self.ids)
