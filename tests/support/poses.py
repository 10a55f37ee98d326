"""Synthetic humanoid keypoints from joint angles, for tests, benchmarks and scripts/measure_box_margins.py.

The skeleton is the football engine's (`simgen.body.standing`): its segment lengths are the same for
every humanoid and every frame of a captured clip (tests/fixtures/motion_smoke.parquet). In it `middle`
sits 0.16 m above the centre of the hip joints, on the lower spine, and the shoulders almost level with
the neck. Built in the body frame (x forward, y left, z up), then turned by a yaw about z and placed on
the pitch; the lowest ankle stands `ANKLE_HEIGHT_M` above the ground (plus `Pose.lift_m` for a jump).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.body.standing import (  # the engine's skeleton (segment lengths)
    ANKLE_HEIGHT_M,
    HIP_HALF_WIDTH_M,
    MIDDLE_ABOVE_HIPS_M,
    SHIN_M,
    SHOULDER_BEHIND_NECK_M,
    SHOULDER_BELOW_NECK_M,
    SHOULDER_HALF_WIDTH_M,
    SPINE_M,
    THIGH_M,
    UPPER_ARM_M,
)
from simgen.vocab import KEYPOINT_INDEX, NUM_KEYPOINTS

Pair = tuple[float, float]  # (left, right)


@dataclass(frozen=True)
class Pose:
    """Joint angles in radians; all zero is upright, arms hanging, facing +x. Pairs: (left, right)."""

    hip_flexion: Pair = (0.0, 0.0)  # thigh forward (+) or back (-)
    hip_abduction: Pair = (0.0, 0.0)  # thigh out to its side
    knee_flexion: Pair = (0.0, 0.0)  # shin back from the thigh line, >= 0
    shoulder_flexion: Pair = (0.0, 0.0)  # upper arm forward and up (+) or back (-)
    shoulder_abduction: Pair = (0.0, 0.0)  # upper arm out to its side and up
    trunk_lean: float = 0.0  # spine forward (+) or back (-) about `middle`
    trunk_side_lean: float = 0.0  # spine to the left (+)
    trunk_twist: float = 0.0  # shoulders turned to the left (+) about the spine
    lift_m: float = 0.0  # lowest ankle above its standing height (a jump)


PRESETS: dict[str, Pose] = {
    "standing": Pose(),
    "running": Pose(
        hip_flexion=(0.6, -0.35), knee_flexion=(0.9, 0.35), shoulder_flexion=(-0.5, 0.6), trunk_lean=0.3
    ),
    "sprinting": Pose(
        hip_flexion=(1.0, -0.5), knee_flexion=(1.6, 0.5), shoulder_flexion=(-0.9, 1.0), trunk_lean=0.45
    ),
    "arms_raised": Pose(shoulder_flexion=(2.9, 2.9), shoulder_abduction=(0.3, 0.3)),
    "leaning": Pose(
        trunk_lean=0.7, knee_flexion=(0.4, 0.4), hip_flexion=(0.3, 0.3), shoulder_flexion=(0.5, 0.5)
    ),
    "kicking": Pose(
        hip_flexion=(-0.1, 1.3),
        knee_flexion=(0.3, 0.2),
        shoulder_abduction=(0.9, 0.7),
        trunk_lean=-0.25,
        trunk_twist=0.3,
    ),
    "jumping": Pose(
        hip_flexion=(0.4, 0.2), knee_flexion=(0.8, 0.6), shoulder_flexion=(2.5, 2.3), lift_m=0.45
    ),
    "crouching": Pose(
        hip_flexion=(1.3, 1.3), knee_flexion=(2.0, 2.0), trunk_lean=0.5, shoulder_flexion=(0.8, 0.8)
    ),
}


def _rot_x(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _limb(flexion: float, abduction: float, side: float) -> NDArray[np.float64]:
    """Unit direction of a limb hanging down, swung forward by flexion, out by abduction."""
    return _rot_x(side * abduction) @ np.array([np.sin(flexion), 0.0, -np.cos(flexion)])


def keypoints(
    pose: Pose, yaw_rad: float = 0.0, position_m: tuple[float, float] = (0.0, 0.0)
) -> NDArray[np.float64]:
    """(12, 3) keypoints in metres of `pose` facing `yaw_rad` (CCW from +x), pelvis above `position_m`."""
    out = np.zeros((NUM_KEYPOINTS, 3))

    def put(name: str, point: NDArray[np.float64]) -> None:
        out[KEYPOINT_INDEX[name]] = point

    for i, (side, sign) in enumerate((("left", 1.0), ("right", -1.0))):
        hip = np.array([0.0, sign * HIP_HALF_WIDTH_M, -MIDDLE_ABOVE_HIPS_M])
        thigh = _limb(pose.hip_flexion[i], pose.hip_abduction[i], sign)
        shin = _limb(pose.hip_flexion[i] - pose.knee_flexion[i], pose.hip_abduction[i], sign)
        put(f"{side}_thigh", hip)
        put(f"{side}_knee", hip + THIGH_M * thigh)
        put(f"{side}_ankle", hip + THIGH_M * thigh + SHIN_M * shin)

    trunk = _rot_x(-pose.trunk_side_lean) @ _rot_y(pose.trunk_lean) @ _rot_z(pose.trunk_twist)
    neck = trunk @ [0.0, 0.0, SPINE_M]
    put("neck", neck)
    for i, (side, sign) in enumerate((("left", 1.0), ("right", -1.0))):
        offset = [-SHOULDER_BEHIND_NECK_M, sign * SHOULDER_HALF_WIDTH_M, -SHOULDER_BELOW_NECK_M]
        shoulder = neck + trunk @ offset
        arm = trunk @ _limb(pose.shoulder_flexion[i], pose.shoulder_abduction[i], sign)
        put(f"{side}_shoulder", shoulder)
        put(f"{side}_elbow", shoulder + UPPER_ARM_M * arm)

    ankles = out[[KEYPOINT_INDEX["left_ankle"], KEYPOINT_INDEX["right_ankle"]], 2]
    out[:, 2] += ANKLE_HEIGHT_M + pose.lift_m - ankles.min()
    out = out @ _rot_z(yaw_rad).T
    out[:, :2] += position_m
    return out


def lying_keypoints(
    yaw_rad: float = 0.0, position_m: tuple[float, float] = (0.0, 0.0)
) -> NDArray[np.float64]:
    """(12, 3) keypoints of a player lying on their right side, head towards `yaw_rad`.

    The standing pose turned so that its up points along the yaw, its left up and its front
    sideways (shoulders and hips one above the other), the spine 0.17 m above the ground.
    """
    turn = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # up -> x, left -> z
    out = keypoints(PRESETS["standing"]) @ turn.T
    out[:, 2] += 0.17 - out[KEYPOINT_INDEX["middle"], 2]
    out = out @ _rot_z(yaw_rad).T
    out[:, :2] += position_m - out[KEYPOINT_INDEX["middle"], :2]
    return out


def random_pose(rng: np.random.Generator) -> Pose:
    """A pose with every angle drawn uniformly from a plausible range for football."""

    def pair(low: float, high: float) -> Pair:
        a, b = rng.uniform(low, high, size=2)
        return (float(a), float(b))

    return Pose(
        hip_flexion=pair(-0.5, 1.4),
        hip_abduction=pair(0.0, 0.5),
        knee_flexion=pair(0.0, 2.0),
        shoulder_flexion=pair(-0.8, 3.0),
        shoulder_abduction=pair(0.0, 2.8),
        trunk_lean=float(rng.uniform(-0.3, 0.8)),
        trunk_side_lean=float(rng.uniform(-0.3, 0.3)),
        trunk_twist=float(rng.uniform(-0.6, 0.6)),
        lift_m=float(rng.uniform(0.0, 0.5)) if rng.uniform() < 0.2 else 0.0,
    )
