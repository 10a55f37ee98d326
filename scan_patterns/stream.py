"""Shot streams: the shots of a head or a sensor in any time window, and frames of merged sweeps.

Every shot is a function of its time alone, so windows can be asked for in any order and
consecutive windows (t0, t1], (t1, t2] continue each other exactly. `density` scales the shots
per second (x2: twice the shots, same pattern drawn at the same speed).
"""

from __future__ import annotations

import math

import numpy as np

from scan_patterns import replay, risley, rose, rotors
from scan_patterns.sensors import HeadSpec, SensorSpec
from scan_patterns.shots import Shots, concatenate, head_rotation, make_shots, rotate
from scan_patterns.timebase import first_shot, shot_times


def _check_density(density: float) -> None:
    if not (density > 0 and math.isfinite(density)):
        raise ValueError(f"density must be a positive number, got {density}")


def pattern_directions(
    head: HeadSpec, t_local_s: np.ndarray, clock: tuple[int, float] | None = None, line: np.ndarray | None = None
) -> np.ndarray:
    """(N, 3) float32 head-frame directions of the head's pattern at head-local times (s); `clock`:
    (first shot index, shots per second) when the times are the head's shot clock; `line`: each
    shot's laser (default laser 0)."""
    model = head.model
    if head.pattern == "risley":
        return risley.directions(model, t_local_s, clock)
    if head.pattern == "rose":
        return rose.directions(model, head.fov_deg, t_local_s)
    if head.pattern == "rotors":
        return rotors.directions(model, t_local_s, line)
    return replay.directions(model, t_local_s, line, head.lasers)


def head_shots(head: HeadSpec, t0_s: float, t1_s: float, density: float = 1.0, index: int = 0) -> Shots:
    """Shots of one head in (t0_s, t1_s], directions in the head frame, `head` column = `index`,
    `line` the laser: shot k of the head's clock fires laser (k - 1) mod lasers."""
    _check_density(density)
    offset = head.time_offset_s
    rate = head.shots_per_s * density
    t_local = shot_times(t0_s + offset, t1_s + offset, rate)
    clock = (first_shot(t0_s + offset, rate), rate)
    line = (np.arange(clock[0] - 1, clock[0] - 1 + len(t_local)) % head.lasers).astype(np.uint8)
    return make_shots(t_local - offset, pattern_directions(head, t_local, clock, line), t0_s, t1_s, index, line)


def shots(sensor: SensorSpec, t0_s: float, t1_s: float, density: float = 1.0) -> Shots:
    """Shots of all heads in (t0_s, t1_s], directions in the sensor frame, head after head."""
    parts = []
    for index, head in enumerate(sensor.heads):
        part = head_shots(head, t0_s, t1_s, density, index)
        if head.yaw_deg or head.pitch_deg:
            part = Shots(
                part.t_s,
                rotate(part.dirs, head_rotation(head.yaw_deg, head.pitch_deg)),
                part.head,
                part.line,
                part.sweep,
                t0_s,
                t1_s,
            )
        parts.append(part)
    return concatenate(parts)


def frame_window(frame_index: int, frame_rate_hz: float) -> tuple[float, float]:
    """(t0, t1] of frame `frame_index` at `frame_rate_hz`: frame k starts where frame k-1 ended."""
    if not frame_rate_hz > 0:
        raise ValueError(f"frame rate must be positive, got {frame_rate_hz}")
    return frame_index / frame_rate_hz, (frame_index + 1) / frame_rate_hz


def frame_shots(
    sensor: SensorSpec,
    frame_index: int,
    frame_rate_hz: float = 10.0,
    density: float = 1.0,
    sweeps_per_frame: int = 1,
) -> Shots:
    """Shots of one output frame at `frame_rate_hz`, merged from `sweeps_per_frame` sweeps.

    The sensor sweeps at frame_rate_hz * sweeps_per_frame (the paper: two 20 Hz sweeps per 10 Hz
    frame); `sweep` says which sweep of the frame each shot belongs to.
    """
    if not 1 <= sweeps_per_frame <= 255:
        raise ValueError(f"sweeps_per_frame must be in 1..255, got {sweeps_per_frame}")
    t0, t1 = frame_window(frame_index, frame_rate_hz)
    out = shots(sensor, t0, t1, density)
    return Shots(
        out.t_s, out.dirs, out.head, out.line, sweep_index(out.t_s, t0, frame_rate_hz, sweeps_per_frame), t0, t1
    )


def sweep_index(t_s: np.ndarray, t0_s: float, frame_rate_hz: float, sweeps_per_frame: int) -> np.ndarray:
    """(N,) uint8: which of a frame's `sweeps_per_frame` sweeps (each (t0 + k / (rate * sweeps), ...]
    long) each shot time t_s (s) of the frame (t0_s, t0_s + 1 / rate] falls in."""
    sweep = np.ceil((np.asarray(t_s) - t0_s) * frame_rate_hz * sweeps_per_frame - 1e-6) - 1
    return np.clip(sweep, 0, sweeps_per_frame - 1).astype(np.uint8)
