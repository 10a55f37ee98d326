"""What a dataset records of each sensor of the scenario."""

from __future__ import annotations

from dataclasses import dataclass


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
