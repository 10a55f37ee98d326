"""A frame as the reader returns it, in every format, the class names of the labels and the frames' clock.

Coordinates are the pitch frame's (origin at the centre spot, x towards the right goal, y left,
z up, metres) whatever the format on disk, and times are game time in every format (the reader
takes a KITTI or OpenPCDet frame's from the manifest: `frame_times`). Fields a format does not hold
are None: KITTI and OpenPCDet keep only x, y, z, intensity and the boxes with their class (and KITTI
tracking the track ids and discontinuity flags); Parquet keeps everything the simulator made.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.vocab import OFFICIAL_CLASS, PLAYER_CLASS


def class_names(team: NDArray[np.str_]) -> NDArray[np.str_]:
    """Class per humanoid from its team: officials are `Official`, players `Pedestrian`."""
    return np.where(np.asarray(team) == "official", OFFICIAL_CLASS, PLAYER_CLASS).astype(np.str_)


def frame_times(start_s: float, frame_rate_hz: float, index: int) -> tuple[float, float]:
    """Game time (s) of frame `index`'s sweep start and of its labels (the middle of its sweep), as
    `simgen.pipeline.clip` computes them from the clip's first sweep start `start_s`."""
    return start_s + index / frame_rate_hz, start_s + (index + 0.5) / frame_rate_hz


@dataclass(frozen=True)
class Frame:
    """One frame of one clip: points and boxes, numpy arrays, pitch frame."""

    clip: str
    index: int  # frame index in the clip, from 0
    points_m: NDArray[np.float32]  # (P, 3) x, y, z
    intensity: NDArray[np.uint8]  # (P,) 0-255
    boxes: NDArray[np.float32]  # (H, 7) x, y, z centre, length, width, height, yaw (radians)
    class_name: NDArray[np.str_]  # (H,) Pedestrian or Official
    track_id: NDArray[np.int32] | None = None  # (H,) Parquet and KITTI tracking
    # Every format (`simgen.datasets.open` fills them from the manifest where the files keep no time):
    time_s: float | None = None  # game time of the start of the sweep(s), seconds
    label_time_s: float | None = None  # game time the boxes describe, seconds
    # Parquet and MCAP only:
    time_offset_s: NDArray[np.float32] | None = None  # (P,) since the frame's start
    sensor: NDArray[np.uint8] | None = None  # (P,)
    head: NDArray[np.uint8] | None = None  # (P,)
    sweep: NDArray[np.uint8] | None = None  # (P,) sweep of the frame (0 .. sweeps_per_frame - 1)
    line: NDArray[np.uint8] | None = None  # (P,) laser of the head that fired the shot (Livox's `line`)
    instance_id: NDArray[np.int32] | None = None  # (P,) track id, 1000 ball, -1 none
    semantic: NDArray[np.uint8] | None = None  # (P,) index into simgen.vocab.SEMANTIC_NAMES
    team: NDArray[np.str_] | None = None  # (H,) left, right, official
    role: NDArray[np.str_] | None = None  # (H,)
    velocity_mps: NDArray[np.float32] | None = None  # (H, 3)
    keypoints_m: NDArray[np.float32] | None = None  # (H, 12, 3)
    num_points: NDArray[np.int32] | None = None  # (H,)
    # Parquet, KITTI tracking and MCAP: (H,) placed by the engine since the previous frame (FrameLabels.discontinuity)
    discontinuity: NDArray[np.bool_] | None = None
