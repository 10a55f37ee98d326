"""The scenario's sensors in the pitch frame: scan-pattern shots turned into rays.

A sensor's clock starts at 0 when its clip's capture starts: frame k of a clip is pattern time
(k / rate, (k + 1) / rate], game time that plus the clip's first captured time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

import scan_patterns
from scan_patterns.shots import head_rotation
from simgen.scan.rays import Rays
from simgen.scan.sensor import Sensor
from simgen.scenario import ScanConfig


def frame_rays(scan: ScanConfig, sensors: Sequence[Sensor], frame_index: int, clip_start_s: float) -> Rays:
    """The rays of every sensor's shots in frame `frame_index`, in the pitch frame (sensors: `scenario_sensors`),
    each with the sweep of the frame it belongs to (`scan.sweeps_per_frame` sweeps merged per frame)."""
    t0, t1 = scan_patterns.frame_window(frame_index, scan.frame_rate_hz)
    heads = []  # (sensor, head index, shots, head -> pitch rotation)
    for sensor in sensors:
        to_pitch = sensor.rotation
        for index, head in enumerate(sensor.heads):
            shots = scan_patterns.head_shots(head, t0, t1, scan.density, index)
            heads.append((sensor, index, shots, to_pitch @ head_rotation(head.yaw_deg, head.pitch_deg)))
    n = sum(len(shots) for _, _, shots, _ in heads)
    rays = Rays(
        np.empty((n, 3)),
        np.empty((n, 3)),
        np.empty(n),
        np.empty(n, np.uint8),
        np.empty(n, np.uint8),
        np.empty(n, np.uint8),
        np.empty(n, np.uint8),
    )
    start = 0
    for sensor, index, shots, rotation in heads:
        _fill_head(
            rays.origin_m,
            rays.direction,
            rays.time_s,
            rays.sensor,
            rays.head,
            start,
            shots.dirs,
            shots.t_s,
            rotation,
            sensor.origin_m,
            clip_start_s,
            sensor.sensor_id,
            index,
        )
        rays.sweep[start : start + len(shots)] = scan_patterns.sweep_index(
            shots.t_s, t0, scan.frame_rate_hz, scan.sweeps_per_frame
        )
        rays.line[start : start + len(shots)] = shots.line
        start += len(shots)
    return rays


@numba.njit(cache=True)
def _fill_head(
    origin,
    direction,
    time_s,
    sensor,
    head,
    start,
    head_directions,
    head_times_s,
    rotation,
    sensor_origin,
    clip_start_s,
    sensor_index,
    head_index,
):
    """Write one head's shots into rays from `start`: directions (float32, head frame) turned into
    the pitch frame by `rotation`, times (s, pattern clock) shifted to game time."""
    for k in range(len(head_times_s)):
        i = start + k
        x, y, z = float(head_directions[k, 0]), float(head_directions[k, 1]), float(head_directions[k, 2])
        for a in range(3):
            origin[i, a] = sensor_origin[a]
            direction[i, a] = rotation[a, 0] * x + rotation[a, 1] * y + rotation[a, 2] * z
        time_s[i] = clip_start_s + head_times_s[k]
        sensor[i] = sensor_index
        head[i] = head_index
