"""`rose`: the paper's polar rose rho = A sin(k theta + theta0), mapped onto a head's field of view.

The paper samples its depth map along rho = 350 sin(3 pi theta + theta0) (pixels). Here rho is the
off-axis angle, A is half the head's field of view, and theta (the angle about the boresight, from
+y towards +z) turns uniformly so that the rose draws `petals_per_frame` petals (half-periods of
the sine, alternately on either side of the centre) in each 1 / `frame_rate_hz` seconds. theta0
advances at `theta0_hz` turns per second, so the rose never closes on itself (k = 3 pi alone is
irrational) and no two windows repeat. The defaults draw ~200 petals/s, the rate at which the
Mid-40's rosette passes through its centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scan_patterns.shots import dirs_from_off_axis
from scan_patterns.timebase import cycles

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


@dataclass(frozen=True)
class RoseParams:
    k: float = 3.0 * math.pi  # the paper's 3 pi
    petals_per_frame: float = 20.0
    frame_rate_hz: float = 10.0  # the frame the petal count refers to
    theta0_hz: float = GOLDEN  # theta0 advance, turns per second

    def __post_init__(self) -> None:
        for name in ("k", "petals_per_frame", "frame_rate_hz"):
            if not getattr(self, name) > 0:
                raise ValueError(f"rose: {name} must be positive, got {getattr(self, name)}")

    @property
    def petals_per_s(self) -> float:
        return self.petals_per_frame * self.frame_rate_hz


def directions(params: RoseParams, fov_deg: float, t_s: NDArray[np.float64]) -> NDArray[np.float32]:
    """(N, 3) float32 head-frame unit directions of the rose at times `t_s` (s)."""
    t_s = np.asarray(t_s, np.float64)
    theta_hz = params.petals_per_s / (2.0 * params.k)  # k theta advances pi per petal
    theta = cycles(t_s, theta_hz).astype(np.float32)
    argument = cycles(t_s, params.petals_per_s / 2.0 + params.theta0_hz).astype(np.float32)  # k theta + theta0
    rho = np.float32(np.radians(fov_deg / 2.0)) * np.sin(argument)
    return dirs_from_off_axis(rho, theta, np.float32)
