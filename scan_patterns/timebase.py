"""Shot clocks: which shots of a head fall in a time window, and when.

A head fires shot k (an integer, any sign) at head-local time k / rate_hz. A window (t0, t1] holds
the shots with t0 < t <= t1, so consecutive windows share no shot and miss none; (0, 4] at
100,000 shots/s is exactly the 400,000 shots of Livox's 4 s files (first at 10 us, last at 4 s).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

_EPS = 1e-6  # shot counts within this of an integer are that integer (float rounding of t * rate)


def first_shot(t0_s: float, rate_hz: float) -> int:
    """Index k of the first shot in (t0, ...] on a clock firing at `rate_hz` (shot k at k / rate)."""
    if not rate_hz > 0:
        raise ValueError(f"shot rate must be positive, got {rate_hz}")
    return math.floor(t0_s * rate_hz + _EPS) + 1


def shot_times(t0_s: float, t1_s: float, rate_hz: float) -> NDArray[np.float64]:
    """Times (s) of the shots in (t0, t1] on a clock firing at `rate_hz`: shot k at k / rate."""
    first, stop = first_shot(t0_s, rate_hz), first_shot(t1_s, rate_hz)
    return np.arange(first, max(first, stop), dtype=np.float64) / rate_hz


def cycles(t_s: NDArray[np.float64], hz: float, phase_rad: float = 0.0) -> NDArray[np.float64]:
    """Angle 2 pi (hz t) + phase, reduced to [0, 2 pi), float64 (exact for long times)."""
    turns = t_s * hz + phase_rad / (2.0 * np.pi)
    turns -= np.floor(turns)
    turns *= 2.0 * np.pi
    return turns
