"""A motion clip between its captured frames: keypoints and ball at any time, linear in time."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from simgen.motion.clip import MotionClip


def interpolate_clip(clip: MotionClip, times_s: NDArray) -> tuple[NDArray, NDArray]:
    """Keypoints (T, H, 12, 3) and ball (T, 3) at `times_s`, linear between captured frames."""
    times = np.asarray(times_s, dtype=np.float64)
    if len(times) and (times.min() < clip.time_s[0] - 1e-9 or times.max() > clip.time_s[-1] + 1e-9):
        raise ValueError(f"times {times.min():.3f}-{times.max():.3f} s outside the clip's {clip.time_s[0]:.3f}-{clip.time_s[-1]:.3f} s")
    upper = np.clip(np.searchsorted(clip.time_s, times, side="right"), 1, clip.num_frames - 1)
    lower = upper - 1
    span = clip.time_s[upper] - clip.time_s[lower]
    w = np.clip((times - clip.time_s[lower]) / span, 0.0, 1.0)
    kp0, kp1 = clip.keypoints_m[lower].astype(np.float64), clip.keypoints_m[upper].astype(np.float64)
    ball0, ball1 = clip.ball_m[lower].astype(np.float64), clip.ball_m[upper].astype(np.float64)
    return kp0 + w[:, None, None, None] * (kp1 - kp0), ball0 + w[:, None] * (ball1 - ball0)
