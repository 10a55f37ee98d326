"""Label boxes: heading, rotation equivariance, containment of the body mesh, fallbacks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simgen.body.heading import DEFAULT, HIPS, SHOULDERS, SPINE, VELOCITY, heading, wrap_angle
from simgen.body.mesh import body_meshes
from simgen.labels.boxes import FACE_NAMES, boxes_from_keypoints, overhang
from simgen.vocab import KEYPOINT_INDEX as I
from tests.support.poses import PRESETS, Pose, keypoints, lying_keypoints, random_pose

TOLERANCE_M = 0.02


def _turn(kp: np.ndarray, yaw: float, shift=(0.0, 0.0)) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    out = kp @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
    out[..., :2] += shift
    return out


def _above_ground_overhang(kp: np.ndarray, velocity=None) -> np.ndarray:
    """(H, 6) how far the mesh reaches beyond each box face, from the ground up (it hides the rest)."""
    vertices = body_meshes(kp, ["left"] * len(kp)).vertices_m
    vertices[..., 2] = np.maximum(vertices[..., 2], 0.0)
    return overhang(vertices, boxes_from_keypoints(kp, velocity))


@pytest.mark.parametrize(
    "name", ["standing", "running", "sprinting", "arms_raised", "leaning", "jumping", "crouching"]
)
def test_pose_facing_x_has_yaw_zero(name):
    kp = keypoints(PRESETS[name])[None]
    assert abs(np.rad2deg(boxes_from_keypoints(kp).yaw_rad[0])) < 1.0
    assert heading(kp).source[0] == SHOULDERS


def test_box_follows_a_twisted_trunk():
    boxes = boxes_from_keypoints(keypoints(Pose(trunk_twist=0.4))[None])
    assert boxes.yaw_rad[0] == pytest.approx(0.4)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    yaw=st.floats(-4 * np.pi, 4 * np.pi),
    shift=st.tuples(st.floats(-50, 50), st.floats(-30, 30)),
)
def test_turning_the_player_turns_the_box(seed, yaw, shift):
    kp = keypoints(random_pose(np.random.default_rng(seed)))[None]
    base, moved = boxes_from_keypoints(kp), boxes_from_keypoints(_turn(kp, yaw, shift))
    assert abs(wrap_angle(moved.yaw_rad - base.yaw_rad - yaw)[0]) < 1e-6
    assert -np.pi < moved.yaw_rad[0] <= np.pi
    np.testing.assert_allclose(moved.centre_m, _turn(base.centre_m, yaw, shift), atol=1e-6)
    np.testing.assert_allclose(moved.size_m, base.size_m, atol=1e-6)


def test_yaw_is_wrapped_to_minus_pi_exclusive():
    boxes = boxes_from_keypoints(_turn(keypoints(PRESETS["standing"])[None], np.pi))
    assert boxes.yaw_rad[0] == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == np.pi and wrap_angle(3 * np.pi) == np.pi


def test_mesh_is_inside_its_box_over_many_poses():
    rng = np.random.default_rng(7)
    poses = list(PRESETS.values()) + [random_pose(rng) for _ in range(400)]
    kp = np.stack([keypoints(p, rng.uniform(-np.pi, np.pi), rng.uniform(-50, 50, 2)) for p in poses])
    reach = _above_ground_overhang(kp)
    assert reach.max() <= TOLERANCE_M, dict(zip(FACE_NAMES, reach.max(axis=0)))


def test_boxes_are_tight_around_the_mesh():
    rng = np.random.default_rng(8)
    kp = np.stack([keypoints(p) for p in [*PRESETS.values(), *(random_pose(rng) for _ in range(50))]])
    slack = -overhang(body_meshes(kp, ["left"] * len(kp)).vertices_m, boxes_from_keypoints(kp))
    assert slack[:, :5].max() < 0.01  # front, back, sides, top: only the mesh's chord error


def test_standing_box():
    boxes = boxes_from_keypoints(keypoints(PRESETS["standing"])[None])
    (_, y, z, length, width, height, yaw) = boxes.array[0]
    assert z - height / 2 == pytest.approx(0.0)  # from the ground
    assert 1.7 <= height <= 1.9
    assert 0.40 <= width <= 0.6 and 0.3 <= length <= 0.6
    assert abs(y) < 1e-9 and yaw == pytest.approx(0.0)


def test_jumping_box_starts_at_the_lowest_body_point():
    kp = keypoints(PRESETS["jumping"])[None]
    boxes = boxes_from_keypoints(kp)
    bottom = boxes.centre_m[0, 2] - boxes.size_m[0, 2] / 2
    lowest = body_meshes(kp, ["left"]).vertices_m[0, :, 2].min()
    assert bottom > 0.3 and bottom == pytest.approx(lowest, abs=0.01)


def test_lying_player_uses_the_spine_and_stays_inside():
    kp = np.stack([lying_keypoints(yaw, (3.0, -2.0)) for yaw in (0.0, 1.0, -2.5)])
    boxes = boxes_from_keypoints(kp)
    assert np.all(heading(kp).source == SPINE)
    np.testing.assert_allclose(boxes.yaw_rad, [0.0, 1.0, -2.5], atol=1e-9)  # towards the head
    assert boxes.size_m[0, 0] > 1.6 and boxes.size_m[0, 2] < 0.6
    assert _above_ground_overhang(kp).max() <= TOLERANCE_M


def test_heading_fallbacks():
    standing = keypoints(PRESETS["standing"])
    no_shoulders = standing.copy()
    no_shoulders[I["left_shoulder"]] = no_shoulders[I["right_shoulder"]]
    point = np.zeros((12, 3))
    kp = np.stack([standing, no_shoulders, point, point])
    velocity = np.array([[0.0, 5.0, 0.0], [0.0, 5.0, 0.0], [0.0, -3.0, 0.0], [0.0, 0.0, 0.0]])
    facing = heading(kp, velocity)
    assert facing.source.tolist() == [SHOULDERS, HIPS, VELOCITY, DEFAULT]
    np.testing.assert_allclose(facing.yaw_rad, [0.0, 0.0, -np.pi / 2, 0.0], atol=1e-12)
    assert heading(kp).source.tolist() == [SHOULDERS, HIPS, DEFAULT, DEFAULT]


@pytest.mark.parametrize("velocity", [None, np.array([[1.0, 1.0, 0.0]] * 5)])
def test_degenerate_poses_give_finite_boxes(velocity):
    standing = keypoints(PRESETS["standing"])
    coincident = standing.copy()
    coincident[I["left_shoulder"]] = coincident[I["right_shoulder"]]
    kp = np.stack([np.zeros((12, 3)), coincident, lying_keypoints(), standing, standing])  # two at one place
    boxes = boxes_from_keypoints(kp, velocity)
    assert np.all(np.isfinite(boxes.array))
    assert np.all(boxes.size_m > 0)
    np.testing.assert_array_equal(boxes.array[3], boxes.array[4])
    assert _above_ground_overhang(kp, velocity).max() <= TOLERANCE_M


def test_engine_skeletons_face_where_knees_bend_and_players_run(motion_clip):
    """On the engine's skeletons, left x up is the front: bent knees point there, runners move there."""
    kp = motion_clip.keypoints_m.astype(np.float64)  # (F, H, 12, 3)
    forward = heading(kp.reshape(-1, 12, 3)).forward.reshape(kp.shape[:2] + (3,))
    hips, knees, ankles = (kp[:, :, [I[f"left_{j}"], I[f"right_{j}"]]] for j in ("thigh", "knee", "ankle"))
    bend = np.einsum("fhsi,fhi->fhs", knees - 0.5 * (hips + ankles), forward)
    assert np.mean(bend[np.abs(bend) > 0.03] > 0) > 0.95
    velocity = np.gradient(kp[:, :, I["middle"]], axis=0) * motion_clip.capture_hz
    speed = np.linalg.norm(velocity[..., :2], axis=-1)
    along = np.einsum("fhi,fhi->fh", velocity, forward)[speed > 2.0] / speed[speed > 2.0]
    assert np.median(along) > 0.8


def test_engine_skeletons_get_tight_adult_boxes(motion_clip):
    kp = motion_clip.keypoints_m.reshape(-1, 12, 3)[::7].astype(np.float64)
    boxes = boxes_from_keypoints(kp)
    assert np.all(np.isfinite(boxes.array))
    length, width, height = np.median(boxes.size_m, axis=0)
    assert 0.4 <= length <= 0.9 and 0.5 <= width <= 0.9 and 1.6 <= height <= 1.9
    assert _above_ground_overhang(kp).max() <= TOLERANCE_M


def test_track_sizes_hold_still_over_the_clip(motion_clip):
    """labels.size: track, through the pipeline on the captured clip: every humanoid's length, width and
    height are the same in every frame (the medians of its enclosing boxes over the clip), its centre on
    the pitch plane and its bottom are the enclosing box's."""
    from simgen.pipeline.clip import label_sizes, render_frames
    from simgen.scenario import parse_scenario

    def frames(scenario):
        return list(render_frames(scenario, motion_clip, 0, 0, 6, label_sizes(scenario, motion_clip)))

    scenario = {"name": "sizes", "scan": {"frame_rate_hz": 10, "frames": 6}, "sensors": [{"preset": "mid40-rose"}]}
    enclosing = frames(parse_scenario(scenario))
    track = frames(parse_scenario({**scenario, "labels": {"size": "track"}}))
    sizes = np.stack([f.labels.boxes[:, 3:6] for f in track])
    assert (
        np.all(sizes == sizes[0]) and np.ptp(np.stack([f.labels.boxes[:, 3] for f in enclosing]), axis=0).max() > 0.05
    )
    for a, b in zip(enclosing, track):
        np.testing.assert_array_equal(a.labels.boxes[:, :2], b.labels.boxes[:, :2])
        np.testing.assert_allclose(
            a.labels.boxes[:, 2] - a.labels.boxes[:, 5] / 2, b.labels.boxes[:, 2] - b.labels.boxes[:, 5] / 2, atol=1e-6
        )
        np.testing.assert_array_equal(a.labels.boxes[:, 6], b.labels.boxes[:, 6])
