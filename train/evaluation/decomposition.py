"""Where a detector's 3D AP goes: TIDE's idea (Bolya et al., 2020) for 3D boxes.

Each detection is matched, greedily by score, to the nearest free labelled box whose centre is within
`MATCH_M` on the pitch plane (the centre-distance AP's rule). Then, one error at a time, the matched
detections get that part of their labelled box (centre x-y, size, heading or centre height), and 3D
AP (KITTI's R40 at IoU 0.5, train.evaluation.detection) is scored again; "all" gives them the whole
box. The gain over the AP as detected is what that error costs. Labelled boxes no detection reaches
within `MATCH_M` are misses, which no fix recovers; how many of them are invisible (no point in
t-2..t) says how many a LiDAR detector could not have found.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from train.evaluation.detection import FrameBoxes, detection_ap, similarities

MATCH_M = 1.0  # a detection within this of a labelled box's centre found it (metres, pitch plane)
# The parts of a box a fix replaces: centre x-y, size (length, width, height), heading, centre height.
PARTS: dict[str, tuple[int, ...]] = {
    "centre": (0, 1),
    "size": (3, 4, 5),
    "heading": (6,),
    "z": (2,),
    "all": tuple(range(7)),
}


@dataclass(frozen=True)
class Decomposition:
    ap: float  # 3D AP R40 in percent, IoU 0.5, as detected
    fixed: dict[str, float]  # the same AP with one part of every matched detection taken from its labelled box
    detections: int
    matched: int  # detections within MATCH_M of a labelled box
    truth: int
    missed: int  # labelled boxes with no detection within MATCH_M
    missed_invisible: int  # of those, boxes with no point in t-2..t

    @property
    def costliest(self) -> str:
        """The error whose fix gains the most AP (of centre, size, heading, z)."""
        return max((part for part in self.fixed if part != "all"), key=lambda part: self.fixed[part])


def _centre_matches(frame: FrameBoxes, closeness: NDArray[np.float64]) -> NDArray[np.int64]:
    """(N,) the labelled box each detection found within MATCH_M, greedily by score; -1: none."""
    found = np.full(len(frame.boxes), -1, np.int64)
    taken = np.zeros(len(frame.truth), bool)
    for i in np.argsort(-frame.scores, kind="stable"):
        free = np.where(taken, -np.inf, closeness[i])
        if len(free) and free.max() >= -MATCH_M:
            found[i] = int(free.argmax())
            taken[found[i]] = True
    return found


def decompose(frames: Sequence[FrameBoxes], visible: Sequence[NDArray[np.bool_]]) -> Decomposition:
    """The decomposition over frames (each with all its labelled boxes; `visible` (G,) per frame)."""
    matches = [_centre_matches(f, c) for f, c in zip(frames, similarities(frames, "centre"))]
    fixed = {}
    for part, columns in PARTS.items():
        fixed_frames = []
        for frame, found in zip(frames, matches):
            boxes = np.array(frame.boxes, np.float32, copy=True).reshape(-1, 7)
            hit = found >= 0
            for column in columns:
                boxes[hit, column] = np.asarray(frame.truth, np.float32).reshape(-1, 7)[found[hit], column]
            fixed_frames.append(replace(frame, boxes=boxes))
        fixed[part] = detection_ap(fixed_frames, "3d")
    missed = [np.setdiff1d(np.arange(len(f.truth)), m[m >= 0]) for f, m in zip(frames, matches)]
    return Decomposition(
        ap=detection_ap(frames, "3d"),
        fixed=fixed,
        detections=sum(len(f.boxes) for f in frames),
        matched=int(sum((m >= 0).sum() for m in matches)),
        truth=sum(len(f.truth) for f in frames),
        missed=sum(len(m) for m in missed),
        missed_invisible=int(sum((~v[m]).sum() for v, m in zip(visible, missed))),
    )
