"""The synthetic pose generator: the engine's skeleton, heights, facing, placement."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.vocab import KEYPOINT_INDEX as I
from tests.support.poses import ANKLE_HEIGHT_M, PRESETS, Pose, keypoints, random_pose


def test_standing_adult_heights():
    kp = keypoints(PRESETS["standing"])
    assert kp[I["left_ankle"], 2] == pytest.approx(ANKLE_HEIGHT_M)
    assert 0.9 <= kp[I["left_thigh"], 2] <= 1.0
    assert 1.55 <= kp[I["neck"], 2] <= 1.65  # upright; the engine's players lean and bend
    assert kp[I["left_shoulder"], 1] > 0 > kp[I["right_shoulder"], 1]  # facing +x, left is +y


def test_yaw_and_position_move_the_pose_rigidly():
    pose = random_pose(np.random.default_rng(3))
    base = keypoints(pose)
    moved = keypoints(pose, yaw_rad=np.pi / 2, position_m=(10.0, -5.0))
    expected = np.stack([-base[:, 1] + 10.0, base[:, 0] - 5.0, base[:, 2]], axis=1)
    np.testing.assert_allclose(moved, expected, atol=1e-12)


def test_lift_raises_the_lowest_ankle():
    kp = keypoints(Pose(lift_m=0.4))
    assert kp[[I["left_ankle"], I["right_ankle"]], 2].min() == pytest.approx(ANKLE_HEIGHT_M + 0.4)


def test_segments_match_the_engine(motion_clip):
    """Joints linked by one rigid segment are as far apart as in the engine's skeletons."""
    links = [
        ("middle", "neck"),
        ("middle", "left_thigh"),
        ("left_thigh", "right_thigh"),
        ("left_thigh", "left_knee"),
    ]
    links += [("left_knee", "left_ankle"), ("neck", "left_shoulder"), ("left_shoulder", "right_shoulder")]
    links += [("left_shoulder", "left_elbow")]
    engine = motion_clip.keypoints_m.reshape(-1, 12, 3)
    ours = keypoints(random_pose(np.random.default_rng(0)))
    for a, b in links:
        length = np.median(np.linalg.norm(engine[:, I[a]] - engine[:, I[b]], axis=1))
        assert np.linalg.norm(ours[I[a]] - ours[I[b]]) == pytest.approx(length, abs=0.002), (a, b)
