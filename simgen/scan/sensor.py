"""A sensor of the scenario, resolved once by the scan stage: `Sensor`, the one description that the
scan, the dataset writers, the manifest (`record`, its JSON form), the Parquet `sensors` table (the
same record as columns), the readers, QA and the viewers use.

A scenario names a sensor by its preset (`SensorConfig`); `Sensor` holds the preset's heads
(`scan_patterns.HeadSpec`: pattern, rate, lasers, field of view, mounting), its pose in the pitch
frame and the rates the scan fired at. A dataset records all of it but the heads, which its
scenario's `custom_sensors` or the preset registry give back (`Sensor.from_record`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

import scan_patterns as sp
from scan_patterns.shots import head_rotation

if TYPE_CHECKING:
    from simgen.scenario import Scenario

#: x, y, z (metres), roll, pitch, yaw (degrees), pitch frame; applied yaw, pitch (positive: looking up), roll.
Pose = tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class Sensor:
    """A sensor of the scenario with its preset's heads, posed in the pitch frame."""

    sensor_id: int  # index in the scenario's sensor list (ScanFrame.sensor, points.sensor)
    name: str
    preset: str  # scan_patterns sensor preset (the scenario's custom_sensors, else the registry)
    pose: Pose
    heads: tuple[sp.HeadSpec, ...]  # the preset's heads
    shots_per_s: float  # all heads, after the density factor
    frame_rate_hz: float
    sweeps_per_frame: int
    density: float  # shots per second as a multiple of the real sensor's

    def record(self) -> dict:
        """What a dataset records of it (a manifest `sensors` entry, a row of the Parquet `sensors` table): its heads
        counted."""
        return {
            "sensor_id": self.sensor_id,
            "name": self.name,
            "preset": self.preset,
            "pose": self.pose,
            "heads": len(self.heads),
            "shots_per_s": self.shots_per_s,
            "frame_rate_hz": self.frame_rate_hz,
            "sweeps_per_frame": self.sweeps_per_frame,
            "density": self.density,
        }

    @classmethod
    def from_record(cls, record: Mapping, scenario: Mapping) -> Sensor:
        """A recorded sensor, its heads from its preset in `scenario` (a dataset's resolved scenario); ValueError if
        the preset is unknown or has another number of heads."""
        try:
            heads = sp.find_sensor(record["preset"], scenario.get("custom_sensors") or []).heads
        except (AttributeError, KeyError, TypeError, ValueError) as error:  # a manifest edited by hand
            raise ValueError(f"sensor preset {record['preset']!r}: {' '.join(str(error).splitlines())[:200]}") from None
        if len(heads) != record["heads"]:
            raise ValueError(
                f"sensor {record['name']!r}: {record['heads']} heads, preset {record['preset']!r} has {len(heads)}"
            )
        fields = {key: value for key, value in record.items() if key not in ("pose", "heads")}
        return cls(**fields, pose=tuple(record["pose"]), heads=heads)

    @property
    def origin_m(self) -> NDArray[np.float64]:
        """(3,) position in the pitch frame, metres."""
        return np.array(self.pose[:3], np.float64)

    @property
    def rotation(self) -> NDArray[np.float64]:
        """(3, 3) sensor frame -> pitch frame: yaw about z, then pitch (positive: up), then roll about x."""
        _, _, _, roll, pitch, yaw = self.pose
        return euler_rotation(yaw, pitch, roll).copy()

    @property
    def boresights(self) -> NDArray[np.float64]:
        """(heads, 3) unit vector along each head's axis, sensor frame."""
        return np.array([head_rotation(h.yaw_deg, h.pitch_deg)[:, 0] for h in self.heads])

    @property
    def half_fov_deg(self) -> NDArray[np.float64]:
        """(heads,) half angle of the cone about each boresight that holds its field of view, degrees."""
        return np.array([h.half_cone_deg for h in self.heads])

    @property
    def boresight_azimuth_rad(self) -> NDArray[np.float64]:
        """(heads,) azimuth of each head's boresight in the pitch frame, counter-clockwise from +x."""
        pitch_frame = self.boresights @ self.rotation.T
        return np.arctan2(pitch_frame[:, 1], pitch_frame[:, 0])

    def view_angles(self, points_m: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Range (m), off-axis angle from the nearest head (deg) and whether in a head's FOV, per point (N, 3)."""
        offset = np.asarray(points_m, np.float64).reshape(-1, 3) - self.origin_m
        range_m = np.linalg.norm(offset, axis=1)
        local = offset @ self.rotation / np.maximum(range_m, 1e-9)[:, None]
        angles = np.degrees(np.arccos(np.clip(local @ self.boresights.T, -1.0, 1.0)))  # (N, heads)
        return range_m, angles.min(axis=1), (angles <= self.half_fov_deg).any(axis=1)


@functools.lru_cache(maxsize=256)
def euler_rotation(yaw_deg: float, pitch_deg: float, roll_deg: float) -> NDArray[np.float64]:
    """(3, 3) sensor frame -> pitch frame of yaw, pitch (positive: up) and roll, degrees (cached: copy to change)."""
    from scipy.spatial.transform import Rotation  # scipy.spatial is slow to import; readers seldom need it

    return Rotation.from_euler("ZYX", [yaw_deg, -pitch_deg, roll_deg], degrees=True).as_matrix()


def scenario_sensors(scenario: Scenario) -> tuple[Sensor, ...]:
    """The scenario's sensors, resolved: each `sensors` entry's preset, pose and the scan's rates."""
    scan = scenario.scan
    return tuple(
        Sensor(
            sensor_id=i,
            name=sensor.name,
            preset=sensor.preset,
            pose=(sensor.pose.x, sensor.pose.y, sensor.pose.z, sensor.pose.roll, sensor.pose.pitch, sensor.pose.yaw),
            heads=spec.heads,
            shots_per_s=shots_per_s,
            frame_rate_hz=scan.frame_rate_hz,
            sweeps_per_frame=scan.sweeps_per_frame,
            density=scan.density,
        )
        for i, (sensor, spec, shots_per_s) in enumerate(
            zip(scenario.sensors, scenario.sensor_specs(), scenario.sensor_shots_per_s(), strict=True)
        )
    )
