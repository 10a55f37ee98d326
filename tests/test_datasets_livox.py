"""Bags as Livox's drivers publish them (`simgen export --ros2-layout livox-custom / livox-v1 / livox-v1-custom`):
decoded with rosbags' typestore built from the drivers' own message definitions (tests/fixtures/livox_msgs, not
simgen's), a message per lidar unit, point by point against the Parquet dataset of the same frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from scipy.spatial.transform import Rotation

import simgen.datasets
from simgen.cli import main
from tests.support.datasets import make_clip, mid40, sensors, with_mid40, write_dataset

FIXTURES = Path(__file__).parent / "fixtures" / "livox_msgs"
SENSORS = [*sensors(), mid40()]  # a Mid-100 (three units) and a Mid-40
#: (sensor id, head, the unit's lidar_id): the units of all sensors in sensor then head order
UNITS = [(0, 0, 0), (0, 1, 1), (0, 2, 2), (1, 0, 3)]
V1_POINT = [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("intensity", 12, 7, 1), ("tag", 16, 2, 1),
            ("line", 17, 2, 1)]  # livox_ros_driver's LivoxPointXyzrtl (lds.h, packed): 18 bytes


@pytest.fixture(scope="module")
def parquet(tmp_path_factory):
    from simgen.datasets import finish_dataset, write_clip

    root = tmp_path_factory.mktemp("livox") / "parquet"
    record = write_clip(root, "parquet", with_mid40(make_clip("clip_0000", 3, points=300), 3), SENSORS, 0)
    finish_dataset(root, "parquet", [record], SENSORS, {"name": "x"}, 3)
    return root


def _driver_typestore():
    """ROS 2 Humble's types plus both drivers' CustomMsg and CustomPoint from their own .msg files."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for package in ("livox_ros_driver2", "livox_ros_driver"):
        for name in ("CustomPoint", "CustomMsg"):
            text = (FIXTURES / package / f"{name}.msg").read_text()
            store.register(get_types_from_msg(text, f"{package}/msg/{name}"))
    return store


def _messages(bag: Path) -> dict[str, list]:
    """Every message of the bag's MCAP by topic, decoded with `_driver_typestore`, by the schema's type name."""
    store, out = _driver_typestore(), {}
    with (bag / f"{bag.name}.mcap").open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append(store.deserialize_cdr(message.data, schema.name))
    return out


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _export(parquet, out, *options) -> None:
    assert main(["export", str(parquet), "-o", str(out), *options]) == 0


def _in_pitch(tf, frame_id: str, xyz: np.ndarray) -> np.ndarray:
    (transform,) = [t.transform for t in tf.transforms if t.child_frame_id == frame_id]
    rotation = Rotation.from_quat([transform.rotation.x, transform.rotation.y, transform.rotation.z,
                                   transform.rotation.w])
    return rotation.apply(xyz.astype(np.float64)) + [transform.translation.x, transform.translation.y,
                                                      transform.translation.z]


def _want(parquet_data, index: int, sensor: int, head: int):
    want = parquet_data.frame("clip_0000", index)
    mine = (want.sensor == sensor) & (want.head == head)
    shot_ns = round(want.time_s * 1e9) + np.rint(want.time_offset_s[mine].astype(np.float64) * 1e9).astype(np.int64)
    return want, mine, shot_ns


@pytest.mark.parametrize("layout, package", [("livox-custom", "livox_ros_driver2"),
                                             ("livox-v1-custom", "livox_ros_driver")])
def test_custom_msg_per_lidar_unit_equals_the_parquet_points(parquet, tmp_path, layout, package):
    out = tmp_path / "bag"
    _export(parquet, out, "--ros2-layout", layout)
    data, topics = simgen.datasets.open(parquet), _messages(out)
    (tf,) = topics["/tf_static"]
    names = {0: "mid100", 1: "mid40"}
    unit_topics = [f"/simgen/{names[s]}/lidar_{h}" for s, h, _ in UNITS]
    assert sorted(topics) == sorted(["/tf_static", "/simgen/boxes", *unit_topics])
    for sensor, head, lidar_id in UNITS:
        messages = topics[f"/simgen/{names[sensor]}/lidar_{head}"]
        assert len(messages) == 3 and all(type(m).__msgtype__ == f"{package}/msg/CustomMsg" for m in messages)
        for index, message in enumerate(messages):
            want, mine, shot_ns = _want(data, index, sensor, head)
            points = message.points
            assert message.lidar_id == lidar_id and message.point_num == len(points) == mine.sum() > 0
            assert message.header.frame_id == names[sensor] and list(message.rsvd) == [0, 0, 0]
            # timebase: the unit's first point, as the drivers stamp a message; offset_time from it
            assert message.timebase == _ns(message.header.stamp) == shot_ns.min()
            np.testing.assert_array_equal([p.offset_time for p in points], shot_ns - shot_ns.min())
            xyz = np.array([[p.x, p.y, p.z] for p in points])
            np.testing.assert_allclose(_in_pitch(tf, names[sensor], xyz), want.points_m[mine], rtol=0, atol=2e-5)
            np.testing.assert_array_equal([p.reflectivity for p in points], want.intensity[mine])
            np.testing.assert_array_equal([p.line for p in points], want.line[mine])
            assert not any(p.tag for p in points)  # one return per shot, no noise flags


def test_v1_pointcloud2_per_lidar_unit_is_the_drivers_18_byte_point(parquet, tmp_path):
    out = tmp_path / "bag"
    _export(parquet, out, "--ros2-layout", "livox-v1")
    data, topics = simgen.datasets.open(parquet), _messages(out)
    (tf,) = topics["/tf_static"]
    names = {0: "mid100", 1: "mid40"}
    point = np.dtype({"names": ["x", "y", "z", "intensity", "tag", "line"],
                      "formats": ["<f4", "<f4", "<f4", "<f4", "u1", "u1"], "offsets": [0, 4, 8, 12, 16, 17]})
    for sensor, head, _ in UNITS:
        for index, cloud in enumerate(topics[f"/simgen/{names[sensor]}/lidar_{head}"]):
            assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == V1_POINT
            assert cloud.point_step == point.itemsize == 18 and not cloud.is_bigendian
            want, mine, shot_ns = _want(data, index, sensor, head)
            got = np.frombuffer(bytes(cloud.data), point)
            assert cloud.width == len(got) == mine.sum() and cloud.row_step == 18 * len(got)
            assert _ns(cloud.header.stamp) == shot_ns.min() and cloud.header.frame_id == names[sensor]
            xyz = np.stack([got["x"], got["y"], got["z"]], 1)
            np.testing.assert_allclose(_in_pitch(tf, names[sensor], xyz), want.points_m[mine], rtol=0, atol=2e-5)
            np.testing.assert_array_equal(got["intensity"], want.intensity[mine])
            np.testing.assert_array_equal(got["line"], want.line[mine])
            assert not got["tag"].any()


def test_units_remapped_to_the_drivers_one_topic_and_frame(tmp_path):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 2, points=200)])  # one Mid-100
    out = tmp_path / "bag"
    _export(tmp_path / "d", out, "--ros2-layout", "livox-custom", "--topic", "livox/lidar", "--frame-id",
            "livox_frame")
    topics = _messages(out)
    assert sorted(topics) == ["/simgen/boxes", "/tf_static", "livox/lidar"]
    ids = [m.lidar_id for m in topics["livox/lidar"]]  # by stamp: each unit's first point
    assert sorted(ids[:3]) == sorted(ids[3:]) == [0, 1, 2]  # every unit once a frame
    assert {m.header.frame_id for m in topics["livox/lidar"]} == {"livox_frame"}
    assert [t.child_frame_id for t in topics["/tf_static"][0].transforms] == ["livox_frame"]
    out = tmp_path / "ids"
    _export(tmp_path / "d", out, "--ros2-layout", "livox-v1", "--topic", "livox/lidar_{lidar_id}")
    assert sorted(_messages(out)) == ["/simgen/boxes", "/tf_static", "livox/lidar_0", "livox/lidar_1", "livox/lidar_2"]


@pytest.mark.parametrize("options, problem", [
    (["--ros2-layout", "livox-v1", "--topic", "livox/lidar"], "gives units the same topic"),
    (["--frame-id", "livox_frame"], "--frame-id: the simgen layout's points are in the pitch frame"),
    (["--ros2-layout", "livox-custom", "--topic", "/x/{serial}"], "--topic '/x/{serial}': not a name template"),
])
def test_names_a_layout_cannot_take_are_one_line_errors(tmp_path, capsys, options, problem):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 2, points=100)])
    assert main(["export", str(tmp_path / "d"), "-o", str(tmp_path / "bag"), *options]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and problem in err and not (tmp_path / "bag").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["d"]


def test_an_mcap_dataset_keeps_no_head_so_a_mid100_is_refused_per_unit(tmp_path, capsys):
    write_dataset(tmp_path / "d", "mcap", [make_clip("clip_0000", 2, points=100)])
    assert main(["export", str(tmp_path / "d"), "-o", str(tmp_path / "bag"), "--ros2-layout", "livox-custom"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "keep no head per point" in err and not (tmp_path / "bag").exists()
