"""Hand-made `MotionClip`s for the renderer's and the noise model's tests: humanoids standing still."""

from __future__ import annotations

import numpy as np

from simgen.motion.clip import MotionClip


def still_clip(poses: list[np.ndarray], teams: list[str], ball=(0.0, 0.0, -5.0)) -> MotionClip:
    """A 1 s clip at 10 Hz of humanoids standing still (ball parked under the ground by default)."""
    kp = np.repeat(np.stack(poses)[None], 11, axis=0).astype(np.float32)
    n = len(poses)
    return MotionClip(
        time_s=np.round(np.arange(11) * 0.1, 6),
        keypoints_m=kp,
        ball_m=np.tile(np.float32(ball), (11, 1)),
        engine_position_m=np.full((11, n, 3), np.nan, np.float32),
        track_id=np.arange(n, dtype=np.int32),
        team=np.array(teams),
        role=np.array(["CM"] * n),
        jersey=np.full(n, -1, np.int16),
        capture_hz=10,
    )
