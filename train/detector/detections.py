"""The detector's output on disk: tracklet files for the tracker, KITTI object labels for other tools.

Tracklets: one `<clip>.npz` per clip with `frame` (N,) int64, `boxes` (N, K, 7) float32 (pitch
frame; oldest first, the box at t last; K = 3 for `late`, 1 otherwise), `scores` (N,) float32 in
[0, 1], `offsets` (K,) int64 (frame offsets of the K boxes: -2, -1, 0) and `clip`. Rows are in
frame order; frames without detections have no rows. Per frame, `boxes` and `scores` are the
fields of train.tracking.types.Tracklets.

KITTI: `<clip>/<frame:06d>.txt` object label lines of the boxes at t, `Pedestrian` and a score,
in the virtual camera that simgen's KITTI datasets use (simgen.datasets.kitti_camera).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from simgen.atomic import atomic_path
from simgen.datasets.kitti_camera import kitti_boxes
from simgen.errors import UserError

KITTI_CLASS = "Pedestrian"


@dataclass(frozen=True)
class ClipTracklets:
    """Every frame's tracklets of one clip."""

    clip: str
    frame: NDArray[np.int64]  # (N,)
    boxes: NDArray[np.float32]  # (N, K, 7)
    scores: NDArray[np.float32]  # (N,)
    offsets: NDArray[np.int64]  # (K,)

    def at(self, frame: int) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """(boxes (n, K, 7), scores (n,)) of one frame."""
        rows = self.frame == frame
        return self.boxes[rows], self.scores[rows]


def clip_tracklets(
    clip: str, frames: Sequence[int], boxes: Sequence[NDArray], scores: Sequence[NDArray]
) -> ClipTracklets:
    """Gather per-frame tracklets (boxes (n, K, 7), scores (n,)) into one table."""
    k = boxes[0].shape[1] if boxes else 1
    return ClipTracklets(
        clip=clip,
        frame=np.concatenate([np.full(len(s), f, np.int64) for f, s in zip(frames, scores)])
        if frames
        else np.zeros(0, np.int64),
        boxes=np.concatenate(boxes).astype(np.float32) if boxes else np.zeros((0, k, 7), np.float32),
        scores=np.concatenate(scores).astype(np.float32) if scores else np.zeros(0, np.float32),
        offsets=np.arange(1 - k, 1, dtype=np.int64),
    )


def write_tracklets(path: Path, tracklets: ClipTracklets) -> None:
    with atomic_path(path) as tmp, open(tmp, "wb") as out:
        np.savez(out, clip=np.str_(tracklets.clip), frame=tracklets.frame, boxes=tracklets.boxes,
                 scores=tracklets.scores, offsets=tracklets.offsets)


def read_tracklets(path: str | Path) -> ClipTracklets:
    try:
        with np.load(path, allow_pickle=False) as data:
            return ClipTracklets(str(data["clip"]), data["frame"], data["boxes"], data["scores"], data["offsets"])
    except (OSError, KeyError, ValueError) as error:
        raise UserError(f"{path}: not a tracklet file ({error.__class__.__name__})") from None


def kitti_lines(boxes: NDArray[np.float32], scores: NDArray[np.float32]) -> list[str]:
    """KITTI object lines `type trunc occ alpha x1 y1 x2 y2 h w l x y z ry score` of boxes (n, 7)."""
    fields = kitti_boxes(boxes)
    lines = []
    for i, score in enumerate(scores):
        numbers = [
            fields["alpha"][i],
            *fields["bbox"][i],
            *fields["dims"][i],
            *fields["location"][i],
            fields["ry"][i],
            score,
        ]
        lines.append(f"{KITTI_CLASS} 0 0 " + " ".join(f"{v:.4f}" for v in numbers))
    return lines


def write_kitti(folder: Path, tracklets: ClipTracklets, frames: Sequence[int]) -> None:
    """One label file per frame in `frames` (empty where nothing was detected), boxes at t."""
    folder.mkdir(parents=True, exist_ok=True)
    for frame in frames:
        boxes, scores = tracklets.at(frame)
        with atomic_path(folder / f"{frame:06d}.txt") as tmp:
            tmp.write_text("".join(line + "\n" for line in kitti_lines(boxes[:, -1], scores)))
