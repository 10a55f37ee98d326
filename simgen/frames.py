"""A labelled frame: what the pipeline hands the dataset writers, one per LiDAR frame."""

from __future__ import annotations

from dataclasses import dataclass

from simgen.labels import FrameLabels
from simgen.render import ScanFrame


@dataclass(frozen=True)
class SensorInfo:
    """A sensor of the scenario, as the `sensors` table records it."""

    sensor_id: int  # index in the scenario's sensor list (ScanFrame.sensor)
    name: str
    preset: str  # scan_patterns sensor preset
    pose: tuple[float, float, float, float, float, float]  # x, y, z (metres), roll, pitch, yaw (degrees), pitch frame
    heads: int
    shots_per_s: float  # all heads, after the density factor
    frame_rate_hz: float
    sweeps_per_frame: int
    density: float


@dataclass(frozen=True)
class LabelledFrame:
    """One frame of one clip: its points and the labels of every humanoid."""

    clip: str  # clip id, e.g. "clip_0003"
    index: int  # frame index in the clip, from 0
    time_s: float  # game time of the start of the frame's sweep(s), seconds
    label_time_s: float  # game time the labels describe (the middle of the sweep), seconds
    scan: ScanFrame
    labels: FrameLabels
