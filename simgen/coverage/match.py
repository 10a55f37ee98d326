"""The scenario's own match, rendered as `simgen generate` renders it (occlusion between players included):
points on every labelled player in every frame, per sensor, with where the player stood."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.scan.sensor import scenario_sensors
from simgen.scenario import Scenario


@dataclass(frozen=True)
class MatchCoverage:
    """Player-frames of the match's first clips: N rows, one per labelled player (not official) per frame."""

    sensor_names: tuple[str, ...]  # (S,)
    position_m: NDArray[np.float64]  # (N, 2) box centre on the pitch at the label time
    distance_m: NDArray[np.float64]  # (N,) horizontal distance to the rig's nearest sensor
    points: NDArray[np.int32]  # (N, S) points of the frame on the player, by sensor
    clips: int
    frames: int  # frames per clip

    @property
    def rig_points(self) -> NDArray[np.int64]:
        """(N,) points of the frame on the player, all sensors."""
        return self.points.sum(axis=1)


def points_by_sensor(instance_id: NDArray, sensor: NDArray, ids: NDArray, num_sensors: int) -> NDArray[np.int32]:
    """Points (H, S) of a frame (instance ids and sensors (P,)) on each of the humanoids `ids` (H,), by sensor."""
    order = np.argsort(ids)
    position = np.searchsorted(ids[order], instance_id)
    position = np.minimum(position, len(ids) - 1)
    hit = ids[order][position] == instance_id
    key = order[position[hit]] * num_sensors + sensor[hit].astype(np.int64)
    return np.bincount(key, minlength=len(ids) * num_sensors).reshape(len(ids), num_sensors).astype(np.int32)


def trimmed(scenario: Scenario, frames: int) -> Scenario:
    """The scenario with its clips cut to their first `frames` frames, the motion captured just long enough:
    the same frames, bit for bit, as the whole scenario renders there."""
    if frames >= scenario.frames_per_clip():
        return scenario
    motion_frames = math.ceil(frames * scenario.motion.capture_hz / scenario.scan.frame_rate_hz - 1e-9) + 1
    data = scenario.model_dump()
    data["motion"]["frames"] = min(motion_frames, scenario.motion.frames)
    data["scan"]["frames"] = frames
    return Scenario.model_validate(data)


def match_coverage(
    scenario: Scenario, clips: int, frames: int, progress: Callable[[str, int], None] | None = None
) -> MatchCoverage:
    """Capture and render the first `clips` clips of the scenario, `frames` frames each (at most the scenario's);
    `progress(stage, count)` is told of each motion frame captured ("capture") and frame rendered ("render")."""
    from simgen.motion.engine import capture_motion
    from simgen.pipeline.clip import engine_seed, label_sizes, render_frames

    scenario = trimmed(scenario, frames)
    frames = scenario.frames_per_clip()
    sensors = scenario_sensors(scenario)
    sensors_xy = np.array([s.origin_m[:2] for s in sensors])
    positions, points = [], []
    for clip_index in range(clips):
        tick = None if progress is None else (lambda n: progress("capture", n))
        clip = capture_motion(scenario.motion, engine_seed(scenario, clip_index), tick)
        players = clip.team != "official"
        for frame in render_frames(scenario, clip, clip_index, 0, frames, label_sizes(scenario, clip)):
            labels, scan = frame.labels, frame.scan
            positions.append(labels.boxes[players, :2].astype(np.float64))
            points.append(points_by_sensor(scan.instance_id, scan.sensor, labels.track_id, len(sensors))[players])
            if progress is not None:
                progress("render", 1)
    position = np.concatenate(positions) if positions else np.zeros((0, 2))
    offset = position[:, None, :] - sensors_xy[None]
    distance = np.hypot(offset[..., 0], offset[..., 1]).min(axis=1)
    return MatchCoverage(
        tuple(s.name for s in sensors),
        position,
        distance,
        np.concatenate(points) if points else np.zeros((0, len(sensors)), np.int32),
        clips,
        frames,
    )
