"""The scenario's sensors in the pitch frame: scan-pattern shots turned into rays.

A sensor's clock starts at 0 when its clip's capture starts: frame k of a clip is pattern time
(k / rate, (k + 1) / rate], game time that plus the clip's first captured time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

import scan_patterns
from simgen.errors import UserError
from simgen.frames import SensorInfo
from simgen.render import Rays
from simgen.scenario import ScanConfig, SensorConfig, SensorPose


def sensor_rotation(pose: SensorPose) -> NDArray[np.float64]:
    """(3, 3) sensor frame -> pitch frame: yaw about z, then pitch (positive: up), then roll about x."""
    return Rotation.from_euler("ZYX", [pose.yaw, -pose.pitch, pose.roll], degrees=True).as_matrix()


def sensor_spec(sensor: SensorConfig) -> scan_patterns.SensorSpec:
    try:
        return scan_patterns.get_sensor(sensor.preset)
    except KeyError:
        names = ", ".join(scan_patterns.sensor_names())
        raise UserError(f"sensors.{sensor.name}.preset: unknown sensor preset '{sensor.preset}' (known: {names})") from None


def sensor_infos(sensors: list[SensorConfig], scan: ScanConfig) -> list[SensorInfo]:
    """What the dataset's `sensors` table records of each sensor."""
    infos = []
    for i, sensor in enumerate(sensors):
        spec = sensor_spec(sensor)
        p = sensor.pose
        infos.append(
            SensorInfo(
                sensor_id=i,
                name=sensor.name,
                preset=sensor.preset,
                pose=(p.x, p.y, p.z, p.roll, p.pitch, p.yaw),
                heads=len(spec.heads),
                shots_per_s=sum(h.shots_per_s for h in spec.heads) * scan.density,
                frame_rate_hz=scan.frame_rate_hz,
                sweeps_per_frame=scan.sweeps_per_frame,
                density=scan.density,
            )
        )
    return infos


def frame_rays(sensors: list[SensorConfig], scan: ScanConfig, frame_index: int, clip_start_s: float) -> Rays:
    """The rays of every sensor's shots in frame `frame_index`, in the pitch frame."""
    parts = []
    for i, sensor in enumerate(sensors):
        shots = scan_patterns.frame_shots(
            sensor_spec(sensor), frame_index, scan.frame_rate_hz, scan.density, scan.sweeps_per_frame
        )
        rotation = sensor_rotation(sensor.pose)
        n = len(shots.t_s)
        directions = shots.dirs.astype(np.float64) @ rotation.T
        origin = np.array([sensor.pose.x, sensor.pose.y, sensor.pose.z])
        parts.append((np.broadcast_to(origin, (n, 3)), directions, clip_start_s + shots.t_s, np.full(n, i, np.uint8), shots.head))
    return Rays(*(np.concatenate(column) for column in zip(*parts)))
