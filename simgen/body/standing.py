"""A humanoid standing upright, arms hanging, as the football engine's skeleton has it (numpy in, numpy out).

The segment lengths are the engine's: the same for every humanoid and every frame of a captured
clip (tests/fixtures/motion_smoke.parquet). `middle` sits 0.16 m above the centre of the hip
joints, on the lower spine; the shoulders almost level with the neck; the ankles `ANKLE_HEIGHT_M`
above the ground. Body frame: x forward, y left, z up; metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from simgen.vocab import KEYPOINT_INDEX, NUM_KEYPOINTS

ANKLE_HEIGHT_M = 0.09  # ankle joint above the ground, standing (the clip's median when still)
SHIN_M = 0.442  # knee -> ankle
THIGH_M = 0.420  # hip -> knee
HIP_HALF_WIDTH_M = 0.087  # centre of the hips -> hip joint
MIDDLE_ABOVE_HIPS_M = 0.159  # centre of the hips -> middle, up
SPINE_M = 0.501  # middle -> neck
SHOULDER_HALF_WIDTH_M = 0.160  # spine -> shoulder joint, sideways
SHOULDER_BELOW_NECK_M = 0.018  # along the spine
SHOULDER_BEHIND_NECK_M = 0.025
UPPER_ARM_M = 0.330  # shoulder -> elbow


def _standing_body() -> NDArray[np.float64]:
    """(12, 3) keypoints of the standing pose in the body frame, `middle` above the origin."""
    out = np.zeros((NUM_KEYPOINTS, 3))
    middle_z = ANKLE_HEIGHT_M + SHIN_M + THIGH_M + MIDDLE_ABOVE_HIPS_M
    for side, sign in (("left", 1.0), ("right", -1.0)):
        hip = np.array([0.0, sign * HIP_HALF_WIDTH_M, middle_z - MIDDLE_ABOVE_HIPS_M])
        out[KEYPOINT_INDEX[f"{side}_thigh"]] = hip
        out[KEYPOINT_INDEX[f"{side}_knee"]] = hip - [0.0, 0.0, THIGH_M]
        out[KEYPOINT_INDEX[f"{side}_ankle"]] = hip - [0.0, 0.0, THIGH_M + SHIN_M]
        shoulder = [-SHOULDER_BEHIND_NECK_M, sign * SHOULDER_HALF_WIDTH_M, middle_z + SPINE_M - SHOULDER_BELOW_NECK_M]
        out[KEYPOINT_INDEX[f"{side}_shoulder"]] = shoulder
        out[KEYPOINT_INDEX[f"{side}_elbow"]] = np.subtract(shoulder, [0.0, 0.0, UPPER_ARM_M])
    out[KEYPOINT_INDEX["middle"]] = [0.0, 0.0, middle_z]
    out[KEYPOINT_INDEX["neck"]] = [0.0, 0.0, middle_z + SPINE_M]
    return out


STANDING_BODY_M = _standing_body()


def standing_keypoints(position_m: ArrayLike, yaw_rad: ArrayLike) -> NDArray[np.float64]:
    """Keypoints (N, 12, 3), metres, of N people standing with `middle` above `position_m` (N, 2), facing
    `yaw_rad` (N,) (counter-clockwise from +x)."""
    position_m, yaw_rad = np.asarray(position_m, np.float64), np.asarray(yaw_rad, np.float64)
    c, s = np.cos(yaw_rad)[:, None], np.sin(yaw_rad)[:, None]
    x, y = STANDING_BODY_M[None, :, 0], STANDING_BODY_M[None, :, 1]
    out = np.empty((len(yaw_rad), NUM_KEYPOINTS, 3))
    out[..., 0] = c * x - s * y + position_m[:, 0, None]
    out[..., 1] = s * x + c * y + position_m[:, 1, None]
    out[..., 2] = STANDING_BODY_M[None, :, 2]
    return out
