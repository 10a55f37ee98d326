"""ROS 2 bags in MCAP: read back with both `mcap` (+ mcap-ros2-support) and `rosbags`, point by point
against the Parquet dataset of the same frames; rosbag2's QoS profiles on every channel; `simgen export`
from Parquet and from KITTI (the same stamps), and in livox_ros_driver2's layout."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability, QosHistory, QosReliability
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

import simgen.datasets
from scan_patterns import get_sensor
from simgen.cli import main
from simgen.datasets.formats.mcap import (
    BOXES_TOPIC,
    LIVOX_LAYOUT,
    SIMGEN_LAYOUT,
    TF_STATIC_TOPIC,
    XYZI_LAYOUT,
    bag_name,
    cloud_array,
    points_topic,
)
from simgen.scan.sensor import Sensor
from tests.support.datasets import make_clip, sensors, write_dataset

SECOND = Sensor(
    1, "mid40 far", "mid40-risley", (10.0, 36.0, 6.0, 0.0, -15.0, -90.0), get_sensor("mid40-risley").heads, 100_000.0,
    10.0, 1, 1.0
)
SENSORS = [*sensors(), SECOND]


def _two_sensor_clip(clip: str, frames: int, seed: int):
    """Factory frames whose points come from two sensors, interleaved."""
    out = []
    for frame in make_clip(clip, frames, seed=seed):
        sensor = (np.arange(len(frame.scan.points_m)) % 3 == 0).astype(np.uint8)
        out.append(dataclasses.replace(frame, scan=dataclasses.replace(frame.scan, sensor=sensor)))
    return out


CLIPS = [_two_sensor_clip("clip_0000", 4, 0), _two_sensor_clip("clip_0001", 3, 1)]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    from simgen.datasets import finish_dataset, write_clip

    root = tmp_path_factory.mktemp("bags")
    for format in ("parquet", "mcap"):
        records = [write_clip(root / format, format, frames, SENSORS, i) for i, frames in enumerate(CLIPS)]
        finish_dataset(root / format, format, records, SENSORS, {"name": "two sensors"}, 3)
    return root


def _mcap_file(bag):
    """The MCAP in the bag directory `bag`."""
    return bag / f"{bag_name(bag)}.mcap"


def _mcap_messages(bag):
    with _mcap_file(bag).open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        messages = [
            (channel.topic, message) for _, channel, _, message in reader.iter_decoded_messages(log_time_order=True)
        ]
    return summary, messages


def _rosbags_messages(path):
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        return [(c.topic, reader.deserialize(raw, c.msgtype)) for c, _, raw in reader.messages()]


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


@pytest.mark.parametrize("library", ["mcap", "rosbags"])
def test_every_point_and_box_matches_the_parquet_dataset(written, library):
    parquet = simgen.datasets.open(written / "parquet")
    for frames in CLIPS:
        clip = frames[0].clip
        path = written / "mcap" / clip
        messages = _mcap_messages(path)[1] if library == "mcap" else _rosbags_messages(path)
        by_topic: dict[str, list] = {}
        for topic, message in messages:
            by_topic.setdefault(topic, []).append(message)
        assert sorted(by_topic) == sorted([BOXES_TOPIC, TF_STATIC_TOPIC, *(points_topic(s.name) for s in SENSORS)])
        for index in range(len(frames)):
            want = parquet.frame(clip, index)
            for info in SENSORS:
                cloud = by_topic[points_topic(info.name)][index]
                mine = want.sensor == info.sensor_id
                got = np.frombuffer(bytes(cloud.data), SIMGEN_LAYOUT.dtype)
                assert cloud.header.frame_id == "pitch" and cloud.width == len(got) == mine.sum()
                assert _ns(cloud.header.stamp) == round(want.time_s * 1e9)
                np.testing.assert_array_equal(np.stack([got["x"], got["y"], got["z"]], 1), want.points_m[mine])
                np.testing.assert_array_equal(got["intensity"], want.intensity[mine])
                np.testing.assert_array_equal(got["line"], want.line[mine])  # the laser, as livox_ros_driver2's line
                np.testing.assert_array_equal(got["instance_id"], want.instance_id[mine])
                assert np.all(np.abs(got["offset_time"] - want.time_offset_s[mine].astype(np.float64) * 1e9) <= 0.5)
                np.testing.assert_array_equal(
                    got["timestamp"], _ns(cloud.header.stamp) + got["offset_time"].astype(np.float64)
                )
            markers = by_topic[BOXES_TOPIC][index].markers
            assert markers[0].action == 3  # DELETEALL: the previous frame's boxes go
            cubes = [m for m in markers if m.ns == "boxes" and m.action == 0]
            texts = [m for m in markers if m.ns == "track_ids"]
            assert [m.id for m in cubes] == [int(t) for t in want.track_id] == [int(m.text) for m in texts]
            assert [m.text for m in cubes] == list(want.class_name)
            assert _ns(markers[0].header.stamp) == round(want.label_time_s * 1e9)
            centres = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for m in cubes]).reshape(
                -1, 3
            )
            sizes = np.array([[m.scale.x, m.scale.y, m.scale.z] for m in cubes]).reshape(-1, 3)
            np.testing.assert_array_equal(centres.astype(np.float32), want.boxes[:, :3])
            np.testing.assert_array_equal(sizes.astype(np.float32), want.boxes[:, 3:6])
            yaw = np.array([2 * np.arctan2(m.pose.orientation.z, m.pose.orientation.w) for m in cubes])
            assert np.all(np.abs(np.angle(np.exp(1j * (yaw - want.boxes[:, 6])))) < 1e-6)


def test_static_transforms_are_the_sensor_poses(written):
    _, messages = _mcap_messages(written / "mcap" / "clip_0000")
    (tf,) = [m for topic, m in messages if topic == TF_STATIC_TOPIC]
    assert [t.child_frame_id for t in tf.transforms] == [s.name for s in SENSORS]
    for transform, info in zip(tf.transforms, SENSORS):
        translation, rotation = transform.transform.translation, transform.transform.rotation
        np.testing.assert_array_equal([translation.x, translation.y, translation.z], info.pose[:3])
        matrix = Rotation.from_quat([rotation.x, rotation.y, rotation.z, rotation.w]).as_matrix()
        np.testing.assert_allclose(matrix, info.rotation, atol=1e-12)
        assert transform.header.frame_id == "pitch"


def test_the_summary_lists_the_ros2_schemas_and_every_message(written):
    summary, messages = _mcap_messages(written / "mcap" / "clip_0000")
    schemas = {s.name for s in summary.schemas.values()}
    assert schemas == {"sensor_msgs/msg/PointCloud2", "visualization_msgs/msg/MarkerArray", "tf2_msgs/msg/TFMessage"}
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    assert summary.statistics.message_count == len(messages) == 1 + len(CLIPS[0]) * (len(SENSORS) + 1)


def test_the_mcap_dataset_reads_back_through_simgen_datasets_open(written):
    parquet, bags = simgen.datasets.open(written / "parquet"), simgen.datasets.open(written / "mcap")
    assert bags.format == "mcap" and len(bags) == len(parquet)
    for want, got in zip(parquet, bags):
        order = np.argsort(want.sensor, kind="stable")  # the bag groups points by sensor
        np.testing.assert_array_equal(got.points_m, want.points_m[order])
        np.testing.assert_array_equal(got.sensor, want.sensor[order])
        np.testing.assert_array_equal(got.instance_id, want.instance_id[order])
        np.testing.assert_array_equal(got.track_id, want.track_id)
        np.testing.assert_array_equal(got.boxes[:, :6], want.boxes[:, :6])
        assert got.time_s == pytest.approx(want.time_s, abs=0.5e-9)  # stamps are whole nanoseconds
        assert got.label_time_s == pytest.approx(want.label_time_s, abs=0.5e-9)


def test_export_from_parquet_equals_the_generated_bag(written, tmp_path):
    out = tmp_path / "clip_0001"  # the bag's name is in its MCAP (rosbag2's metadata record)
    assert main(["export", str(written / "parquet"), "--format", "mcap", "-o", str(out), "--clip", "clip_0001"]) == 0
    for name in ("clip_0001.mcap", "metadata.yaml"):
        assert (out / name).read_bytes() == (written / "mcap" / "clip_0001" / name).read_bytes()


def _channel_metadata(bag) -> dict[str, dict[str, str]]:
    with _mcap_file(bag).open("rb") as stream:
        return {c.topic: c.metadata for c in make_reader(stream).get_summary().channels.values()}


def _stamps(messages) -> dict[str, list[int]]:
    """Header stamps (ns) by topic; a MarkerArray's are its first marker's."""
    out: dict[str, list[int]] = {}
    for topic, message in messages:
        header = (
            message.markers[0].header
            if topic == BOXES_TOPIC
            else message.transforms[0].header
            if topic == TF_STATIC_TOPIC
            else message.header
        )
        out.setdefault(topic, []).append(_ns(header.stamp))
    return out


def test_every_channel_carries_rosbag2s_offered_qos_profiles(written, tmp_path):
    exported = tmp_path / "kitti.mcap"
    write_dataset(tmp_path / "kitti", "kitti", [make_clip("clip_0000", 2)])
    assert main(["export", str(tmp_path / "kitti"), "-o", str(exported)]) == 0
    for path in (written / "mcap" / "clip_0000", exported):
        metadata = _channel_metadata(path)
        with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            offered = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        assert set(offered) == set(metadata) and TF_STATIC_TOPIC in offered and BOXES_TOPIC in offered
        for topic, (profile,) in offered.items():
            (written_yaml,) = yaml.safe_load(metadata[topic]["offered_qos_profiles"])  # rosbag2's keys, one profile
            assert set(written_yaml) == {
                "history",
                "depth",
                "reliability",
                "durability",
                "deadline",
                "lifespan",
                "liveliness",
                "liveliness_lease_duration",
                "avoid_ros_namespace_conventions",
            }
            assert profile.reliability == QosReliability.RELIABLE and profile.history == QosHistory.KEEP_LAST
            # tf2 and RViz subscribe to /tf_static transient local: played back volatile, the poses would never arrive
            latched = QosDurability.TRANSIENT_LOCAL if topic == TF_STATIC_TOPIC else QosDurability.VOLATILE
            assert (
                profile.durability == latched
                and profile.depth >= 1
                and (topic != TF_STATIC_TOPIC or profile.depth == 1)
            )


def test_exports_of_one_clip_from_parquet_and_from_kitti_have_the_same_stamps(tmp_path, capsys):
    clip = make_clip("clip_0000", 5)
    for format in ("parquet", "kitti"):
        write_dataset(tmp_path / format, format, [clip])
        assert main(["export", str(tmp_path / format), "-o", str(tmp_path / f"{format}.mcap"), "--frames", "1:4"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 3  # the two summaries and, for KITTI, one line on what it cannot carry
    assert f"{tmp_path / 'kitti.mcap'}: kitti keeps no sensor, head, time or instance per point" in out
    parquet, kitti = (_mcap_messages(tmp_path / f"{format}.mcap")[1] for format in ("parquet", "kitti"))
    stamps = _stamps(parquet)
    assert stamps[points_topic(sensors()[0].name)] == _stamps(kitti)["/simgen/points"]
    assert (
        stamps[BOXES_TOPIC] == _stamps(kitti)[BOXES_TOPIC]
        and stamps[TF_STATIC_TOPIC] == _stamps(kitti)[TF_STATIC_TOPIC]
    )
    want = [clip[i] for i in range(1, 4)]
    assert stamps[BOXES_TOPIC] == [round(f.label_time_s * 1e9) for f in want]  # boxes at the label time
    assert stamps[TF_STATIC_TOPIC] == [round(want[0].time_s * 1e9)]  # playback starts with the first frame
    with _mcap_file(tmp_path / "kitti.mcap").open("rb") as stream:
        log_times = [m.log_time for _, _, m in make_reader(stream).iter_messages(log_time_order=True)]
    assert log_times[0] == round(want[0].time_s * 1e9) == min(log_times)


def test_export_from_kitti_has_one_points_topic_of_what_kitti_keeps(tmp_path, capsys):
    write_dataset(tmp_path / "kitti", "kitti", [make_clip("clip_0000", 3)])
    out = tmp_path / "kitti.mcap"
    assert main(["export", str(tmp_path / "kitti"), "-o", str(out), "--frames", "1:3"]) == 0
    assert capsys.readouterr().out.endswith(
        f"{out}: 2 frames of clip_0000, 5 messages (ROS 2, MCAP, xyzi points), in kitti.mcap and metadata.yaml\n"
    )
    kitti = simgen.datasets.open(tmp_path / "kitti")
    clouds = [m for topic, m in _rosbags_messages(out) if topic == "/simgen/points"]
    for index, cloud in zip((1, 2), clouds):
        got = cloud_array(cloud, XYZI_LAYOUT)
        assert [f.name for f in cloud.fields] == ["x", "y", "z", "intensity"] and cloud.point_step == 16
        want = kitti.frame("clip_0000", index)
        np.testing.assert_array_equal(np.stack([got["x"], got["y"], got["z"]], 1), want.points_m)
        np.testing.assert_array_equal(got["intensity"], want.intensity)
    assert main(["export", str(tmp_path / "kitti"), "-o", str(tmp_path)]) == 2
    assert capsys.readouterr().err == f"simgen export: error: {tmp_path}: already exists\n"
    assert main(["export", str(tmp_path / "kitti"), "-o", str(tmp_path / "livox.mcap"), "--ros2-layout", "livox"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--ros2-layout livox: a kitti dataset keeps no sensor" in err
    assert not (tmp_path / "livox.mcap").exists()


def test_the_livox_layout_is_the_drivers_26_byte_point_in_each_sensors_frame(written, tmp_path):
    out = tmp_path / "livox.mcap"
    assert main(["export", str(written / "parquet"), "-o", str(out), "--ros2-layout", "livox"]) == 0
    parquet = simgen.datasets.open(written / "parquet")
    by_topic: dict[str, list] = {}
    for topic, message in _rosbags_messages(out):
        by_topic.setdefault(topic, []).append(message)
    (tf,) = by_topic[TF_STATIC_TOPIC]
    poses = {t.child_frame_id: t.transform for t in tf.transforms}
    for info in SENSORS:
        transform = poses[info.name]
        rotation = Rotation.from_quat(
            [transform.rotation.x, transform.rotation.y, transform.rotation.z, transform.rotation.w]
        )
        origin = [transform.translation.x, transform.translation.y, transform.translation.z]
        for index, cloud in enumerate(by_topic[points_topic(info.name)]):
            # livox_ros_driver2's PointCloud2 (lddc.cpp): these fields, packed (LivoxPointXyzrtlt)
            assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == [
                ("x", 0, 7, 1),
                ("y", 4, 7, 1),
                ("z", 8, 7, 1),
                ("intensity", 12, 7, 1),
                ("tag", 16, 2, 1),
                ("line", 17, 2, 1),
                ("timestamp", 18, 8, 1),
            ]
            assert cloud.point_step == 26 and cloud.header.frame_id == info.name and not cloud.is_bigendian
            got, want = cloud_array(cloud, LIVOX_LAYOUT), parquet.frame("clip_0000", index)
            mine = want.sensor == info.sensor_id
            in_pitch = rotation.apply(np.stack([got["x"], got["y"], got["z"]], 1).astype(np.float64)) + origin
            np.testing.assert_allclose(in_pitch, want.points_m[mine], rtol=0, atol=2e-5)  # float32 metres within 70 m
            np.testing.assert_array_equal(got["line"], want.line[mine])
            np.testing.assert_array_equal(got["intensity"], want.intensity[mine])
            assert np.all(
                np.abs(got["timestamp"] - (want.time_s + want.time_offset_s[mine].astype(np.float64)) * 1e9) <= 1
            )


def test_each_bag_is_a_rosbag2_directory_whose_metadata_lists_its_mcap_and_topics(written):
    bag = written / "mcap" / "clip_0000"
    assert sorted(p.name for p in bag.iterdir()) == ["clip_0000.mcap", "metadata.yaml"]
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    summary, messages = _mcap_messages(bag)
    assert info["storage_identifier"] == "mcap" and info["relative_file_paths"] == ["clip_0000.mcap"]
    assert info["message_count"] == len(messages)
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]}
    assert counts == {topic: sum(1 for t, _ in messages if t == topic) for topic, _ in messages}
    assert info["starting_time"]["nanoseconds_since_epoch"] == min(m.log_time for m in _raw(bag))
    types = {t["topic_metadata"]["name"]: t["topic_metadata"]["type"] for t in info["topics_with_message_count"]}
    channels = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert types == channels


def _raw(bag):
    with _mcap_file(bag).open("rb") as stream:
        return [message for _, _, message in make_reader(stream).iter_messages()]
