"""Motion clips for the tests: hand-made ones of humanoids standing still (renderer, noise model), and the
acceptance checks of a captured one (the committed fixture, a live capture)."""

from __future__ import annotations

import numpy as np

from simgen.motion.clip import MotionClip
from simgen.vocab import KEYPOINT_INDEX

NECK, MIDDLE = KEYPOINT_INDEX["neck"], KEYPOINT_INDEX["middle"]
ANKLES = [KEYPOINT_INDEX["left_ankle"], KEYPOINT_INDEX["right_ankle"]]


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


def standing_mask(clip: MotionClip, max_speed_mps: float = 0.3, max_trunk_tilt_deg: float = 20) -> np.ndarray:
    """(F, H) True where a humanoid stands: pelvis slower than `max_speed_mps`, trunk upright."""
    middle = clip.keypoints_m[:, :, MIDDLE]
    speed = np.linalg.norm(np.gradient(middle[..., :2], clip.time_s, axis=0), axis=-1)
    trunk = clip.keypoints_m[:, :, NECK] - middle
    tilt_deg = np.degrees(np.arccos(trunk[..., 2] / np.linalg.norm(trunk, axis=-1)))
    return (speed < max_speed_mps) & (tilt_deg < max_trunk_tilt_deg)


def assert_plausible_skeletons(clip: MotionClip) -> None:
    """The acceptance checks of a captured clip (also run on a live capture in test_engine.py)."""
    assert clip.keypoints_m.shape == (clip.num_frames, clip.num_humanoids, 12, 3)
    assert np.isfinite(clip.keypoints_m).all() and np.isfinite(clip.ball_m).all()
    players = clip.team != "official"
    assert players.sum() == 22
    assert len(np.unique(clip.track_id)) == clip.num_humanoids

    standing = standing_mask(clip)
    assert standing[:, players].mean() > 0.05, "expected some standing players"
    ankles_z = clip.keypoints_m[:, :, ANKLES, 2]
    neck_z = clip.keypoints_m[:, :, NECK, 2]
    assert (ankles_z[standing] < 0.25).all(), ankles_z[standing].max()
    assert ((neck_z[standing] > 1.3) & (neck_z[standing] < 1.9)).all(), (neck_z[standing].min(), neck_z[standing].max())

    # Track ids stay with the same body: nobody's pelvis jumps between consecutive frames.
    step = np.linalg.norm(np.diff(clip.keypoints_m[:, :, MIDDLE], axis=0), axis=-1)
    assert step.max() < 12.0 / clip.capture_hz, step.max()  # faster than 12 m/s would be a swap

    # Each player's keypoint centre agrees with the engine's own reported position (our frame).
    known = np.isfinite(clip.engine_position_m[..., 0])
    assert known[:, players].any(axis=0).all()
    centre = clip.keypoints_m.mean(axis=2)[..., :2]
    distance = np.linalg.norm(centre - clip.engine_position_m[..., :2], axis=-1)
    assert distance[known].max() < 0.5, distance[known].max()
