"""Online timing: frames paced at a sensor's rate, late and dropped frames counted, each stage's latency per frame.

A sensor at `rate_hz` delivers frame k at start + k / rate_hz (k counts the run's frames, clip after
clip). `Pacer.wait(k)` sleeps until then; a frame is *late* when its tracks come after the next frame
arrived (its latency exceeded one period), and *dropped* when, as it is picked up, `queue` newer frames
are already waiting (a driver's bounded queue, livox_ros_driver2 publishing with keep-last 64): it is then
never detected nor tracked.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

STAGES = ("read", "pillars", "network", "decode", "track")  # a stage a source lacks takes 0 ms
DEFAULT_QUEUE = 64


class Pacer:
    """Frame arrival times at `rate_hz` (None: as fast as they are processed, nothing late or dropped)."""

    def __init__(self, rate_hz: float | None, queue: int = DEFAULT_QUEUE, frames: int | None = None) -> None:
        self.period = None if rate_hz is None else 1.0 / rate_hz
        self.queue, self.frames, self.start = queue, frames, None  # frames: how many the sensor will deliver
        self.late = self.dropped = 0

    def wait(self, k: int) -> bool:
        """Block until frame k arrives; False when it is dropped (the queue behind it is full)."""
        if self.period is None:
            return True
        now = time.perf_counter()
        self.start = now if self.start is None else self.start
        arrival = self.start + k * self.period
        if now < arrival:
            time.sleep(arrival - now)
            return True
        arrived = math.floor((now - self.start) / self.period)
        waiting = (arrived if self.frames is None else min(arrived, self.frames - 1)) - k
        if waiting >= self.queue:
            self.dropped += 1
            return False
        return True

    def done(self, k: int) -> None:
        """Frame k's tracks are out: late if after frame k + 1 arrived."""
        if self.period is not None and time.perf_counter() > self.start + (k + 1) * self.period:
            self.late += 1


@dataclass
class Stopwatch:
    """One frame's stage times: `lap(stage)` charges the time since the last lap to that stage. `clock`: wall
    time (the default), or e.g. `time.process_time` for the CPU time of the process (a benchmark on a shared
    machine)."""

    clock: Callable[[], float] = time.perf_counter
    last: float = 0.0
    ms: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STAGES, 0.0))

    def __post_init__(self) -> None:
        self.last = self.clock()

    def lap(self, stage: str) -> None:
        now = self.clock()
        self.ms[stage] += 1000.0 * (now - self.last)
        self.last = now


@dataclass
class LatencyLog:
    """Every frame's stage times, in the order processed."""

    rows: list[tuple[str, int, dict[str, float]]] = field(default_factory=list)

    def add(self, clip: str, frame: int, watch: Stopwatch) -> None:
        self.rows.append((clip, frame, dict(watch.ms)))

    def write(self, path: Path) -> None:
        with open(path, "w", newline="") as out:
            writer = csv.writer(out, lineterminator="\n")
            writer.writerow(["clip", "frame", *(f"{s}_ms" for s in STAGES), "total_ms"])
            for clip, frame, ms in self.rows:
                writer.writerow([clip, frame, *(f"{ms[s]:.3f}" for s in STAGES), f"{sum(ms.values()):.3f}"])

    def summary(self) -> str:
        """`latency per frame (ms, p50 / p99 / max): read a / b / c, ..., total ...`."""
        if not self.rows:
            return "latency: no frame processed"
        table = np.array([[ms[s] for s in STAGES] for _, _, ms in self.rows])
        columns = [*zip(STAGES, table.T), ("total", table.sum(axis=1))]
        parts = [f"{name} {np.percentile(v, 50):.1f} / {np.percentile(v, 99):.1f} / {v.max():.1f}"
                 for name, v in columns]
        return f"latency per frame (ms, p50 / p99 / max over {len(self.rows)} frames): " + ", ".join(parts)
