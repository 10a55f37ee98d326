"""Motion clips: the committed capture is physically plausible and round-trips through Parquet."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import MOTION_FIXTURE

from simgen.errors import UserError
from simgen.motion.clip import MotionClip
from simgen.motion.clip_io import read_clip, read_clip_arrays, write_clip, write_clip_arrays
from simgen.vocab import KEYPOINT_INDEX

NECK, MIDDLE = KEYPOINT_INDEX["neck"], KEYPOINT_INDEX["middle"]
ANKLES = [KEYPOINT_INDEX["left_ankle"], KEYPOINT_INDEX["right_ankle"]]


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


def test_fixture_skeletons_are_plausible(motion_clip):
    assert motion_clip.num_frames >= 200
    assert set(motion_clip.team) == {"left", "right", "official"}
    assert_plausible_skeletons(motion_clip)


def test_fixture_pitch_frame(motion_clip):
    """Everyone stays near the 105 x 68 m pitch; the left team's goalkeeper guards x = -52.5."""
    xy = motion_clip.keypoints_m[..., :2]
    assert (np.abs(xy[..., 0]) < 56).all() and (np.abs(xy[..., 1]) < 38).all()
    left_gk = (motion_clip.team == "left") & (motion_clip.role == "GK")
    right_gk = (motion_clip.team == "right") & (motion_clip.role == "GK")
    assert motion_clip.keypoints_m[:, left_gk, MIDDLE, 0].mean() < -40
    assert motion_clip.keypoints_m[:, right_gk, MIDDLE, 0].mean() > 40
    assert (motion_clip.ball_m[:, 2] >= 0).all()


def test_fixture_left_is_left(motion_clip):
    """Right-handed skeletons: seen from above, the left shoulder is to the left of the facing direction."""
    kp = motion_clip.keypoints_m
    left = kp[:, :, KEYPOINT_INDEX["left_shoulder"]]
    right = kp[:, :, KEYPOINT_INDEX["right_shoulder"]]
    across = left - right
    # Facing direction from the knees (they bend forward) relative to the hips.
    knees = kp[:, :, [KEYPOINT_INDEX["left_knee"], KEYPOINT_INDEX["right_knee"]]].mean(axis=2)
    hips = kp[:, :, [KEYPOINT_INDEX["left_thigh"], KEYPOINT_INDEX["right_thigh"]]].mean(axis=2)
    forward = knees - hips
    # z-component of forward x across > 0 means `across` points to the left of `forward`.
    cross_z = forward[..., 0] * across[..., 1] - forward[..., 1] * across[..., 0]
    assert (cross_z > 0).mean() > 0.8


CLIP_FIELDS = ("time_s", "keypoints_m", "ball_m", "engine_position_m", "track_id", "team", "role", "jersey",
               "placed_s", "ball_placed_s", "game_mode")


def test_round_trip_is_exact(motion_clip, tmp_path):
    path = write_clip(motion_clip, tmp_path / "again.parquet")
    again = read_clip(path)
    for name in CLIP_FIELDS:
        np.testing.assert_array_equal(getattr(again, name), getattr(motion_clip, name))
    assert again.capture_hz == motion_clip.capture_hz and again.metadata == motion_clip.metadata
    assert path.read_bytes() == write_clip(again, tmp_path / "third.parquet").read_bytes()


def test_arrays_round_trip_is_exact_and_mapped(motion_clip, tmp_path):
    again = read_clip_arrays(write_clip_arrays(motion_clip, tmp_path / "arrays"))
    for name in CLIP_FIELDS:
        np.testing.assert_array_equal(getattr(again, name), getattr(motion_clip, name))
        assert getattr(again, name).dtype == getattr(motion_clip, name).dtype, name
    assert isinstance(again.keypoints_m, np.memmap) and not again.keypoints_m.flags.writeable  # mapped, not read
    assert again.capture_hz == motion_clip.capture_hz and again.metadata == motion_clip.metadata
    original = write_clip(motion_clip, tmp_path / "original.parquet").read_bytes()
    assert write_clip(again, tmp_path / "mapped.parquet").read_bytes() == original


def test_unreadable_arrays_are_one_line(motion_clip, tmp_path):
    def refused(directory):
        with pytest.raises(UserError) as error:
            read_clip_arrays(directory)
        assert "\n" not in str(error.value) and str(directory) in str(error.value)

    refused(tmp_path / "absent")
    truncated = write_clip_arrays(motion_clip, tmp_path / "truncated")
    (truncated / "keypoints_m.npy").write_bytes((truncated / "keypoints_m.npy").read_bytes()[:1000])
    refused(truncated)
    short = write_clip_arrays(motion_clip, tmp_path / "short")
    np.save(short / "ball_m.npy", motion_clip.ball_m[:-1])
    refused(short)
    (short / "clip.json").write_text("{not json")
    refused(short)
    (short / "clip.json").write_text("[]")
    refused(short)


def test_readable_by_plain_pyarrow_with_units():
    table = pq.read_table(MOTION_FIXTURE)
    assert b"metres" in table.schema.field("keypoints_m").metadata[b"doc"]
    assert table.num_rows == len(set(table["frame"].to_pylist())) * 25


def test_not_a_clip_is_one_line(tmp_path):
    bogus = tmp_path / "bogus.parquet"
    bogus.write_bytes(b"PAR1 not really")
    with pytest.raises(UserError, match="not a readable Parquet motion clip"):
        read_clip(bogus)
    with pytest.raises(UserError, match="no such motion clip"):
        read_clip(tmp_path / "absent.parquet")
    table = pq.read_table(MOTION_FIXTURE)
    pq.write_table(table.slice(0, 0), tmp_path / "empty.parquet")
    with pytest.raises(UserError, match="a motion clip without frames"):
        read_clip(tmp_path / "empty.parquet")
    pq.write_table(table.slice(0, 30), tmp_path / "ragged.parquet")  # frame 0 whole, frame 1 five humanoids
    with pytest.raises(UserError, match="rows are not whole frames"):
        read_clip(tmp_path / "ragged.parquet")
    pq.write_table(table.drop_columns(["keypoints_m"]), tmp_path / "no_keypoints.parquet")
    with pytest.raises(UserError, match="not a simgen motion clip .*keypoints_m"):
        read_clip(tmp_path / "no_keypoints.parquet")
    pq.write_table(table.replace_schema_metadata({}), tmp_path / "plain.parquet")
    with pytest.raises(UserError, match="not a simgen motion clip"):
        read_clip(tmp_path / "plain.parquet")
