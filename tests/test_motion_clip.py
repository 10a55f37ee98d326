"""Motion clips: the committed capture is physically plausible and round-trips through Parquet."""

from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq
import pytest

from simgen.errors import UserError
from simgen.motion.clip_io import read_clip, read_clip_arrays, write_clip, write_clip_arrays
from simgen.vocab import KEYPOINT_INDEX
from tests.support import MOTION_FIXTURE
from tests.support.clips import assert_plausible_skeletons

MIDDLE = KEYPOINT_INDEX["middle"]


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
    with pytest.raises(UserError, match=r"not a simgen motion clip .*keypoints_m"):
        read_clip(tmp_path / "no_keypoints.parquet")
    pq.write_table(table.replace_schema_metadata({}), tmp_path / "plain.parquet")
    with pytest.raises(UserError, match="not a simgen motion clip"):
        read_clip(tmp_path / "plain.parquet")
