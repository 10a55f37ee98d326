"""Detections made elsewhere, as the tracker's per-frame `Tracklets`: KITTI object files with a score, or
tracklet files of `simgen-train detect`, checked whole before anything is tracked (KITTI files read again frame
by frame as they are tracked: memory flat in a clip's length).

KITTI: `DIR/<clip>/<frame:06d>.txt`, one file per frame (a frame without a file has no detections),
16 columns a line: type, truncated, occluded, alpha, the 2D box (4), h w l, x y z (the bottom centre in
simgen's virtual KITTI camera, simgen.datasets.kitti_camera), rotation_y, score in [0, 1]. Every box
becomes the pitch frame's (x, y, z, length, width, height, yaw).

Single-frame detections (KITTI files, or tracklet files of a single-frame model, K = 1) become
tracklets that stand still: the box at t also at t-2 and t-1, so the 3D DIoU tracker compares each
detection with the tracks' last two boxes, frame to frame, as AB3DMOT associates detections.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.kitti_camera import pitch_boxes
from simgen.errors import UserError
from train.detector.detections import ClipTracklets, read_tracklets
from train.tracking.types import TRACKLET_LEN, Tracklets

KITTI_COLUMNS = 16  # KITTI's 15 object columns and the score
FRAME_FILE = re.compile(r"^(\d{6})\.txt$")
MAX_DETECTIONS_PER_FRAME = 10_000


def still_tracklets(boxes: NDArray[np.float64], scores: NDArray[np.float64]) -> Tracklets:
    """Tracklets (N, 3, 7) of single-frame boxes (N, 7): the box at t at t-2 and t-1 too."""
    return Tracklets(np.repeat(np.asarray(boxes, np.float64)[:, None], TRACKLET_LEN, axis=1), scores)


def as_tracklets(boxes: NDArray[np.floating], scores: NDArray[np.floating]) -> Tracklets:
    """Tracklets from (N, K, 7) boxes, K = 3 as they are, K = 1 standing still."""
    return Tracklets(boxes, scores) if boxes.shape[1] == TRACKLET_LEN else still_tracklets(boxes[:, -1], scores)


def check_boxes(boxes: NDArray[np.floating], scores: NDArray[np.floating], where: str) -> None:
    """Finite numbers, sizes above zero, scores in [0, 1]; else one UserError line naming `where`."""
    if not (np.isfinite(boxes).all() and np.isfinite(scores).all()):
        raise UserError(f"{where}: a number is NaN or infinite")
    if (boxes[..., 3:6] <= 0).any():
        raise UserError(f"{where}: a box of zero or negative size")
    if ((scores < 0) | (scores > 1)).any():
        raise UserError(f"{where}: a score outside [0, 1]")


def parse_kitti(text: str, where: str) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Boxes (n, 7) in the pitch frame and scores (n,) of one KITTI detection file's text."""
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != KITTI_COLUMNS:
            raise UserError(f"{where} line {number}: {len(fields)} columns, expected {KITTI_COLUMNS} "
                            "(KITTI's 15 and the score)")
        try:
            values = [float(v) for v in fields[1:]]
        except ValueError:
            raise UserError(f"{where} line {number}: a column that is not a number") from None
        if not all(math.isfinite(v) for v in values):
            raise UserError(f"{where} line {number}: a number is NaN or infinite")
        rows.append(values)
        if len(rows) > MAX_DETECTIONS_PER_FRAME:
            raise UserError(f"{where}: more than {MAX_DETECTIONS_PER_FRAME:,} detections in one frame")
    table = np.asarray(rows, np.float64).reshape(-1, KITTI_COLUMNS - 1)
    dims, location, ry, scores = table[:, 7:10], table[:, 10:13], table[:, 13], table[:, 14]
    if (dims <= 0).any():
        raise UserError(f"{where}: a box of zero or negative size")
    boxes = pitch_boxes(dims, location, ry)
    check_boxes(boxes, scores, where)
    return boxes, scores.astype(np.float32)


def _read_kitti(path: Path) -> Tracklets:
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a text file") from None
    return still_tracklets(*parse_kitti(text, str(path)))


class KittiClip:
    """A clip's KITTI detection files (`folder/<frame:06d>.txt`, frames 0 .. frames - 1): all checked when
    opened, each read again when its frame is asked for (`get`), so that memory stays flat in the clip's length."""

    def __init__(self, folder: Path, frames: int) -> None:
        self.folder = folder
        self.has_file = np.zeros(frames, bool)  # a bit a frame, not a path: 54,000 frames in 54 kB
        for path in sorted(folder.iterdir()):
            match = FRAME_FILE.match(path.name)
            if not match or not path.is_file():
                raise UserError(f"{path}: not a detection file (expected <frame:06d>.txt)")
            frame = int(match.group(1))
            if frame >= frames:
                raise UserError(f"{path}: frame {frame} beyond the clip's {frames} frames")
            _read_kitti(path)
            self.has_file[frame] = True

    def get(self, frame: int, default: Tracklets) -> Tracklets:
        """The frame's detections as still tracklets; `default` where it has no file."""
        return _read_kitti(self.folder / f"{frame:06d}.txt") if self.has_file[frame] else default


class TrackletClip:
    """A `simgen-train detect` tracklet file of clip `clip` (frames 0 .. frames - 1), checked whole; `get`: a
    frame's tracklets."""

    def __init__(self, path: Path, clip: str, frames: int) -> None:
        data: ClipTracklets = read_tracklets(path)
        if data.clip != clip:
            raise UserError(f"{path}: holds clip {data.clip!r}, not {clip!r}")
        if data.boxes.ndim != 3 or data.boxes.shape[1:] not in ((1, 7), (TRACKLET_LEN, 7)) or \
                len(data.scores) != len(data.frame) or len(data.boxes) != len(data.frame):
            raise UserError(f"{path}: boxes of shape {data.boxes.shape}, expected (N, 1 or 3, 7) with a frame and "
                            "score each")
        if (np.diff(data.frame) < 0).any():
            raise UserError(f"{path}: frames out of order")
        if len(data.frame) and not 0 <= data.frame[0] <= data.frame[-1] < frames:
            raise UserError(f"{path}: frames {data.frame[0]}-{data.frame[-1]} outside the clip's 0-{frames - 1}")
        check_boxes(data.boxes, data.scores, str(path))
        self.data = data

    def get(self, frame: int, default: Tracklets) -> Tracklets:
        """The frame's tracklets; `default` where it has none."""
        start, stop = np.searchsorted(self.data.frame, [frame, frame + 1])
        if start == stop:
            return default
        return as_tracklets(self.data.boxes[start:stop], self.data.scores[start:stop])
