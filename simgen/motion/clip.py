"""A motion clip: the skeletons of every humanoid and the ball over time, pitch frame (`simgen.vocab`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class MotionClip:
    """Skeletons of every humanoid and the ball over a clip.

    F frames at `capture_hz`, H humanoids (left team, right team, officials), in the pitch frame.
    """

    time_s: np.ndarray  # (F,) float64, game time since kick-off, seconds
    keypoints_m: np.ndarray  # (F, H, 12, 3) float32, metres, order of simgen.vocab.KEYPOINT_NAMES
    ball_m: np.ndarray  # (F, 3) float32, ball centre, metres
    engine_position_m: np.ndarray  # (F, H, 3) float32: the engine's own player position; NaN for officials
    track_id: np.ndarray  # (H,) int32, stable over the clip
    team: np.ndarray  # (H,) str: "left", "right" or "official"
    role: np.ndarray  # (H,) str: GK, CB, ... for players; referee or linesman
    jersey: np.ndarray  # (H,) int16; -1: the engine has no shirt numbers
    capture_hz: int
    metadata: dict = field(default_factory=dict)  # level, seed, engine version...

    @property
    def num_frames(self) -> int:
        return len(self.time_s)

    @property
    def num_humanoids(self) -> int:
        return len(self.track_id)
