"""A motion clip between its captured frames: keypoints and ball at any time, linear in time within
a segment, never across a placement.

Where the engine placed a humanoid (or the ball) between two captured frames (`MotionClip.placed_s`),
times before the placement see its pose of the earlier frame and times from the placement on see its
pose of the later frame: never a pose in between. At `capture_hz: 100` those frames are the physics
steps on either side of the placement, so this is exact; at 10 Hz a placed humanoid holds a pose for
up to 0.1 s.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from simgen.motion.clip import MotionClip


def _bracket(clip: MotionClip, times_s: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Times (T,) as float64, and the captured frames around them: lower and upper (T,) indices."""
    times = np.asarray(times_s, dtype=np.float64)
    if len(times) and (times.min() < clip.time_s[0] - 1e-9 or times.max() > clip.time_s[-1] + 1e-9):
        raise ValueError(
            f"times {times.min():.3f}-{times.max():.3f} s outside the clip's "
            f"{clip.time_s[0]:.3f}-{clip.time_s[-1]:.3f} s"
        )
    upper = np.clip(np.searchsorted(clip.time_s, times, side="right"), 1, clip.num_frames - 1)
    return times, upper - 1, upper


def _weights(clip: MotionClip, times: NDArray, lower: NDArray, upper: NDArray, placed_s: NDArray) -> NDArray:
    """Weights of the upper frame, (T,) or (T, H) as `placed_s` (F,) or (F, H): linear, or 0 before and
    1 from a placement in (lower, upper]."""
    span = clip.time_s[upper] - clip.time_s[lower]
    linear = np.clip((times - clip.time_s[lower]) / span, 0.0, 1.0)
    placed = placed_s[upper]
    times = times.reshape(times.shape + (1,) * (placed.ndim - 1))
    linear = linear.reshape(times.shape)
    with np.errstate(invalid="ignore"):  # NaN: no placement
        return np.where(np.isnan(placed), linear, (times >= placed).astype(np.float64))


def interpolate_clip(clip: MotionClip, times_s: NDArray) -> tuple[NDArray, NDArray]:
    """Keypoints (T, H, 12, 3) and ball (T, 3) at `times_s`, linear between captured frames within a segment."""
    times, lower, upper = _bracket(clip, times_s)
    w = _weights(clip, times, lower, upper, clip.placed_s)[:, :, None, None]
    w_ball = _weights(clip, times, lower, upper, clip.ball_placed_s)[:, None]
    kp0, kp1 = clip.keypoints_m[lower].astype(np.float64), clip.keypoints_m[upper].astype(np.float64)
    ball0, ball1 = clip.ball_m[lower].astype(np.float64), clip.ball_m[upper].astype(np.float64)
    return kp0 + w * (kp1 - kp0), ball0 + w_ball * (ball1 - ball0)


def segment_index(clip: MotionClip, times_s: NDArray) -> NDArray[np.int64]:
    """(T, H): how many times the engine had placed each humanoid by each time (s). Two times with the
    same index lie in one segment of its motion."""
    times, lower, upper = _bracket(clip, times_s)
    before = np.cumsum(~np.isnan(clip.placed_s), axis=0)[lower]  # placements up to the lower frame
    with np.errstate(invalid="ignore"):
        return before + (clip.placed_s[upper] <= times[:, None])
