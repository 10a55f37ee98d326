"""The scenario's sensors in the pitch frame: scan-pattern shots turned into rays.

A sensor's clock starts at 0 when its clip's capture starts: frame k of a clip is pattern time
(k / rate, (k + 1) / rate], game time that plus the clip's first captured time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

import scan_patterns
from scan_patterns.shots import rotate
from simgen.frames import SensorInfo
from simgen.render import Rays
from simgen.scenario import Scenario, SensorPose


def sensor_rotation(pose: SensorPose) -> NDArray[np.float64]:
    """(3, 3) sensor frame -> pitch frame: yaw about z, then pitch (positive: up), then roll about x."""
    return Rotation.from_euler("ZYX", [pose.yaw, -pose.pitch, pose.roll], degrees=True).as_matrix()


def sensor_infos(scenario: Scenario) -> list[SensorInfo]:
    """What the dataset's `sensors` table records of each sensor."""
    infos = []
    for i, (sensor, spec) in enumerate(zip(scenario.sensors, scenario.sensor_specs())):
        p = sensor.pose
        infos.append(
            SensorInfo(
                sensor_id=i,
                name=sensor.name,
                preset=sensor.preset,
                pose=(p.x, p.y, p.z, p.roll, p.pitch, p.yaw),
                heads=len(spec.heads),
                shots_per_s=spec.shots_per_s * scenario.scan.density,
                frame_rate_hz=scenario.scan.frame_rate_hz,
                sweeps_per_frame=scenario.scan.sweeps_per_frame,
                density=scenario.scan.density,
            )
        )
    return infos


def frame_rays(scenario: Scenario, specs: list[scan_patterns.SensorSpec], frame_index: int, clip_start_s: float) -> Rays:
    """The rays of every sensor's shots in frame `frame_index`, in the pitch frame (specs: `Scenario.sensor_specs()`)."""
    parts = []
    scan = scenario.scan
    for i, (sensor, spec) in enumerate(zip(scenario.sensors, specs)):
        shots = scan_patterns.frame_shots(spec, frame_index, scan.frame_rate_hz, scan.density, scan.sweeps_per_frame)
        rotation = sensor_rotation(sensor.pose)
        n = len(shots.t_s)
        directions = rotate(shots.dirs.astype(np.float64), rotation)
        origin = np.array([sensor.pose.x, sensor.pose.y, sensor.pose.z])
        parts.append((np.broadcast_to(origin, (n, 3)), directions, clip_start_s + shots.t_s, np.full(n, i, np.uint8), shots.head))
    return Rays(*(np.concatenate(column) for column in zip(*parts)))
