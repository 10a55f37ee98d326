"""Every format reads back, through simgen.datasets.open, the points and boxes it was given."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

import simgen.datasets
from simgen.datasets import FORMATS
from simgen.datasets.frame import class_names
from simgen.errors import UserError
from tests.support.datasets import sample_clips, sensors, write_dataset

CLIPS = sample_clips()


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    root = tmp_path_factory.mktemp("datasets")
    for format in FORMATS:
        write_dataset(root / format, format, CLIPS)
    return {format: simgen.datasets.open(root / format) for format in FORMATS}


def _same_yaw(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(np.abs(np.angle(np.exp(1j * (a.astype(np.float64) - b))) <= 4e-7)))


def _assert_same_boxes(got: np.ndarray, want: np.ndarray) -> None:
    assert got.dtype == np.float32 and got.shape == want.shape
    np.testing.assert_array_equal(got[:, :6], want[:, :6])  # exact: the conversions are
    assert _same_yaw(got[:, 6], want[:, 6])


@pytest.mark.parametrize("format", FORMATS)
def test_every_frame_round_trips(datasets, format):
    data = datasets[format]
    assert data.clips == tuple(c[0].clip for c in CLIPS)
    assert len(data) == sum(map(len, CLIPS))
    for frames in CLIPS:
        assert data.num_frames(frames[0].clip) == len(frames)
        for source in frames:
            frame = data.frame(source.clip, source.index)
            assert (frame.clip, frame.index) == (source.clip, source.index)
            assert frame.points_m.dtype == np.float32 and frame.intensity.dtype == np.uint8
            np.testing.assert_array_equal(frame.points_m, source.scan.points_m)
            np.testing.assert_array_equal(frame.intensity, source.scan.intensity)
            _assert_same_boxes(frame.boxes, source.labels.boxes)
            np.testing.assert_array_equal(frame.class_name, class_names(source.labels.team))
            if format in ("parquet", "kitti_tracking", "mcap"):
                np.testing.assert_array_equal(frame.track_id, source.labels.track_id)
                np.testing.assert_array_equal(frame.discontinuity, source.labels.discontinuity)
            else:
                assert frame.track_id is None and frame.discontinuity is None


@pytest.mark.parametrize("format", FORMATS)
def test_every_format_gives_each_frame_its_game_time(datasets, format):
    """KITTI and OpenPCDet files keep no time: the reader takes it from the clip's start in the manifest."""
    for frames in CLIPS:
        for source in frames:
            frame = datasets[format].frame(source.clip, source.index)
            if format == "mcap":  # stamps are whole nanoseconds
                assert frame.time_s == pytest.approx(source.time_s, abs=0.5e-9)
                assert frame.label_time_s == pytest.approx(source.label_time_s, abs=0.5e-9)
            else:
                assert (frame.time_s, frame.label_time_s) == (source.time_s, source.label_time_s)


def test_the_card_names_replay_files_without_their_folders(tmp_path):
    from simgen.datasets import finish_dataset, write_clip

    pattern = str(tmp_path / "patterns" / "mine.npz")
    scenario = {
        "name": "mine",
        "custom_sensors": [{"name": "mine", "heads": [{"pattern": "replay", "params": {"file": pattern}}]}],
    }
    records = [write_clip(tmp_path / "d", "kitti", CLIPS[0], sensors(), 0)]
    manifest = finish_dataset(tmp_path / "d", "kitti", records, sensors(), scenario, 1)
    card = (tmp_path / "d" / "README.md").read_text()
    assert '"file": "mine.npz"' in card and str(tmp_path) not in card
    # the manifest keeps the path
    assert manifest.scenario["custom_sensors"][0]["heads"][0]["params"]["file"] == pattern


@pytest.mark.parametrize("format", FORMATS)
def test_every_format_reads_back_the_sensors_it_was_written_with(datasets, format):
    assert datasets[format].manifest.sensors == tuple(sensors())  # heads too, resolved from the preset


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ({"preset": "nope"}, "sensor preset 'nope': unknown sensor 'nope'"),
        ({"heads": 2}, "sensor 'mid100': 2 heads, preset 'mid100-risley' has 3"),
    ],
)
def test_a_sensor_its_preset_does_not_describe_is_one_line(datasets, tmp_path, edit, message):
    root = tmp_path / "edited"
    shutil.copytree(datasets["kitti"].root, root)
    manifest = json.loads((root / "manifest.json").read_text())
    manifest["sensors"][0].update(edit)
    (root / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(UserError, match=f"manifest.json: malformed manifest: {re.escape(message)}"):
        simgen.datasets.open(root)


def test_parquet_keeps_everything_the_simulator_made(datasets):
    source = CLIPS[1][3]
    frame = datasets["parquet"].frame(source.clip, source.index)
    scan, labels = source.scan, source.labels
    for name in ("time_offset_s", "sensor", "head", "line", "instance_id", "semantic"):
        np.testing.assert_array_equal(getattr(frame, name), getattr(scan, name), err_msg=name)
    for name in ("team", "role", "velocity_mps", "keypoints_m", "num_points"):
        np.testing.assert_array_equal(getattr(frame, name), getattr(labels, name), err_msg=name)
    assert (frame.time_s, frame.label_time_s) == (source.time_s, source.label_time_s)
    np.testing.assert_array_equal(frame.boxes, labels.boxes)


@pytest.mark.parametrize("format", ["kitti", "kitti_tracking", "openpcdet"])
def test_formats_agree_with_parquet(datasets, format):
    for parquet, other in zip(datasets["parquet"], datasets[format]):
        np.testing.assert_array_equal(other.points_m, parquet.points_m)
        np.testing.assert_array_equal(other.intensity, parquet.intensity)
        _assert_same_boxes(other.boxes, parquet.boxes)


def test_sequence_is_consecutive_frames_ending_at_index(datasets):
    data = datasets["kitti_tracking"]
    frames = data.sequence("clip_0001", 3, length=3)
    assert [f.index for f in frames] == [1, 2, 3]
    np.testing.assert_array_equal(frames[-1].points_m, CLIPS[1][3].scan.points_m)
    with pytest.raises(UserError, match="no 3 frames ending at frame 1"):
        data.sequence("clip_0001", 1, length=3)


def test_bad_clip_or_index_is_one_line(datasets):
    data = datasets["parquet"]
    with pytest.raises(UserError, match="no clip 'clip_9'"):
        data.frame("clip_9", 0)
    with pytest.raises(UserError, match="frames 0-3, not 4"):
        data.frame("clip_0000", 4)


def test_split_is_by_clip(datasets):
    data = datasets["openpcdet"]
    assert [data.split(c) for c in data.clips] == ["train", "train", "val"]
    root = data.root / "ImageSets"
    val = (root / "val.txt").read_text().split()
    assert val == ["020000", "020001"]
    assert len((root / "train.txt").read_text().split()) == 8


@pytest.mark.parametrize("format", FORMATS)
def test_a_format_reads_back_what_it_says_it_carries(datasets, format):
    """`Carries` is what `simgen verify`, `qa` and `export` go by: it must match the frames the reader gives."""
    data = datasets[format]
    carries = data.plugin.carries
    for frame in data:
        assert (frame.track_id is not None, frame.discontinuity is not None) == (carries.track_ids, carries.track_ids)
        per_point = (frame.time_offset_s, frame.line, frame.instance_id)
        assert [field is not None for field in per_point] == [carries.point_fields] * 3
        assert (frame.sensor is not None) == (carries.point_fields or carries.units)
        assert (frame.head is not None) == carries.units
        assert (frame.num_points is not None) == carries.point_counts
