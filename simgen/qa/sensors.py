"""A dataset's sensors posed in the pitch frame, from its manifest: where each stands, where each
head looks, and at what range and off-axis angle it sees a point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import scan_patterns as sp
from scan_patterns.shots import head_rotation
from simgen.errors import UserError
from simgen.scan.sensor_rig import sensor_rotation
from simgen.scenario import SensorPose


@dataclass(frozen=True)
class SensorGeometry:
    """A dataset's sensor in the pitch frame: position, axes and its heads' boresights."""

    name: str
    preset: str
    spec: sp.SensorSpec
    origin_m: NDArray[np.float64]  # (3,)
    rotation: NDArray[np.float64]  # (3, 3) sensor frame -> pitch frame
    boresights: NDArray[np.float64]  # (heads, 3) unit vectors, sensor frame
    half_fov_deg: NDArray[np.float64]  # (heads,) half angle of the cone about each boresight holding its field of view

    @property
    def boresight_azimuth_rad(self) -> NDArray[np.float64]:
        """(heads,) azimuth of each head's boresight in the pitch frame, counter-clockwise from +x."""
        pitch_frame = self.boresights @ self.rotation.T
        return np.arctan2(pitch_frame[:, 1], pitch_frame[:, 0])


def sensor_spec(preset: str, scenario: dict) -> sp.SensorSpec:
    """The scan-pattern sensor of a preset name: the scenario's own `custom_sensors`, else the registry."""
    try:
        for spec in scenario.get("custom_sensors") or []:
            if spec.get("name") == preset:
                return sp.make_sensor(spec)
    except (AttributeError, KeyError, TypeError, ValueError) as error:  # a manifest edited by hand
        raise UserError(
            f"custom sensor {preset!r} of the dataset's scenario: {' '.join(str(error).splitlines())[:200]}"
        ) from None
    return sp.get_sensor(preset)


def sensor_geometry(info: dict, scenario: dict) -> SensorGeometry:
    """A manifest `sensors` entry (pose x, y, z metres, roll, pitch, yaw degrees) posed in the pitch frame."""
    x, y, z, roll, pitch, yaw = info["pose"]
    spec = sensor_spec(info["preset"], scenario)
    return SensorGeometry(
        name=info["name"],
        preset=info["preset"],
        spec=spec,
        origin_m=np.array([x, y, z], np.float64),
        rotation=sensor_rotation(SensorPose(x=x, y=y, z=z, roll=roll, pitch=pitch, yaw=yaw)),
        boresights=np.array([head_rotation(h.yaw_deg, h.pitch_deg)[:, 0] for h in spec.heads]),
        half_fov_deg=np.array([h.half_cone_deg for h in spec.heads]),
    )


def view_angles(sensor: SensorGeometry, points_m: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Range (m), off-axis angle from the nearest head (deg) and whether in a head's FOV, per point (N, 3)."""
    offset = np.asarray(points_m, np.float64).reshape(-1, 3) - sensor.origin_m
    range_m = np.linalg.norm(offset, axis=1)
    local = offset @ sensor.rotation / np.maximum(range_m, 1e-9)[:, None]
    angles = np.degrees(np.arccos(np.clip(local @ sensor.boresights.T, -1.0, 1.0)))  # (N, heads)
    return range_m, angles.min(axis=1), (angles <= sensor.half_fov_deg).any(axis=1)
