"""Rays: the shots of one sweep of every sensor, in the pitch frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Rays:
    """Shots of one sweep in the pitch frame."""

    origin_m: NDArray[np.float64]  # (N, 3)
    direction: NDArray[np.float64]  # (N, 3) unit
    time_s: NDArray[np.float64]  # (N,) game time of each shot
    sensor: NDArray[np.uint8]  # (N,) index of the sensor in the scenario
    head: NDArray[np.uint8]  # (N,) index of the head in its sensor
    sweep: NDArray[np.uint8] = field(default=None)  # (N,) sweep of the frame (0 .. sweeps_per_frame - 1); default all 0
    line: NDArray[np.uint8] = field(default=None)  # (N,) laser of the head that fired (Livox's `line`); default all 0

    def __post_init__(self) -> None:
        if self.sweep is None:  # one sweep per frame
            object.__setattr__(self, "sweep", np.zeros(len(self.time_s), np.uint8))
        if self.line is None:  # one laser per head
            object.__setattr__(self, "line", np.zeros(len(self.time_s), np.uint8))
