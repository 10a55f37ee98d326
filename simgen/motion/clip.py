"""A motion clip: the skeletons of every humanoid and the ball over time, pitch frame (`simgen.vocab`).

Placements: before a restart (free kick, goal kick, throw-in) the engine puts players, and the ball,
where the restart wants them, in one physics step: a jump of metres that no run explains. A clip
records when each happened (`placed_s`, `ball_placed_s`) so that nothing is interpolated across it
(`simgen.motion.interpolate`): the motion between two placements of a humanoid is one segment.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: The engine's game modes (gfootball's e_GameMode), by the value `MotionClip.game_mode` stores.
GAME_MODES = ("normal", "kick_off", "goal_kick", "free_kick", "corner", "throw_in", "penalty")


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
    #: (F, H) float64: game time (s) at which the engine placed humanoid h, in (time_s[f-1], time_s[f]];
    #: NaN where it was not placed. None (a clip made without an engine): no placements.
    placed_s: np.ndarray | None = None
    ball_placed_s: np.ndarray | None = None  # (F,) float64, the same for the ball
    #: (F,) int8, the engine's game mode at each frame (GAME_MODES); -1 where unknown
    game_mode: np.ndarray | None = None

    def __post_init__(self) -> None:
        frames, humanoids = len(self.time_s), len(self.track_id)
        defaults = {"placed_s": np.full((frames, humanoids), np.nan), "ball_placed_s": np.full(frames, np.nan),
                    "game_mode": np.full(frames, -1, np.int8)}
        for name, default in defaults.items():
            if getattr(self, name) is None:
                object.__setattr__(self, name, default)

    @property
    def num_frames(self) -> int:
        return len(self.time_s)

    @property
    def num_humanoids(self) -> int:
        return len(self.track_id)
