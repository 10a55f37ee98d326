"""A labelled frame: what the pipeline hands the dataset writers, one per LiDAR frame."""

from __future__ import annotations

from dataclasses import dataclass

from simgen.labels.boxes import FrameLabels
from simgen.render.frame import ScanFrame


@dataclass(frozen=True)
class LabelledFrame:
    """One frame of one clip: its points and the labels of every humanoid."""

    clip: str  # clip id, e.g. "clip_0003"
    index: int  # frame index in the clip, from 0
    time_s: float  # game time of the start of the frame's sweep(s), seconds
    label_time_s: float  # game time the labels describe (the middle of the sweep), seconds
    scan: ScanFrame
    labels: FrameLabels
