"""The `mcap` format: its writer, reader and plug-in. A clip as a ROS 2 bag in MCAP (no ROS install), as Livox
users record theirs: the directory `<clip id>/` with `<clip id>.mcap` and rosbag2's `metadata.yaml`; `simgen
export` and `simgen-train track` write and read bags in its other layouts.

A bag is a rosbag2 directory: `<name>/<name>.mcap` beside the `metadata.yaml` that `ros2 bag info` reads,
written with rosbags' public `Writer` and its typestore's `serialize_cdr`, and read with `mcap` and
mcap-ros2-support's decoder. These packages are imported only by the functions that write or read a bag, so
that reading a dataset of another format (or training on one) does not need them.

Topics (CDR-encoded, ROS 2 Humble message definitions), each channel with rosbag2's
`offered_qos_profiles` metadata (`QOS_PROFILES`), which `ros2 bag play` offers again:

- `/simgen/<sensor name>/points`, `sensor_msgs/msg/PointCloud2`, one per sensor and frame (empty
  frames too, so the k-th message of a topic is frame k), in one of three `PointLayout`s:
  `SIMGEN_LAYOUT` (the default): the `pitch` frame (metres), livox_ros_driver2's packed 26-byte point
  (`x y z` float32 at 0, 4, 8, `intensity` float32 at 12 (reflectivity 0-255), `tag` uint8 at 16 (0:
  simgen has no return flags), `line` uint8 at 17 (the laser that fired), `timestamp` float64 at 18 (the shot's
  time, ns, on the stamps' clock)), then simgen's own `offset_time` uint32 at 26 (ns since the header
  stamp, as Livox's CustomMsg) and `instance_id` int32 at 30 (track id, 1000 the ball, -1 nothing);
  `LIVOX_LAYOUT`: exactly the driver's 26 bytes, in the sensor's own frame (`frame_id` its name, posed
  on `/tf_static`); `XYZI_LAYOUT`: x, y, z, intensity in the pitch frame on one topic,
  `/simgen/points`, for datasets that keep no sensor, head, time or instance per point (KITTI, OpenPCDet).
- Or, as Livox's drivers publish each lidar, a message per lidar unit (a sensor's head, `units.LidarUnit`) and
  frame on `/simgen/<sensor name>/lidar_<head>`, in the sensor's frame, stamped at the unit's first point:
  `LIVOX_CUSTOM_LAYOUT` livox_ros_driver2's `CustomMsg`, `LIVOX_V1_LAYOUT` livox_ros_driver's 18-byte
  PointCloud2 (x, y, z, intensity, tag, line), `LIVOX_V1_CUSTOM_LAYOUT` its `CustomMsg` (`livox_msgs`);
  `Naming` renames topics and frames (`--topic`, `--frame-id`).
- `/simgen/boxes`, `visualization_msgs/msg/MarkerArray` per frame: DELETEALL, then per humanoid a
  CUBE (namespace `boxes`, marker id = track id, `text` the class, which RViz does not draw on a
  cube) and a TEXT_VIEW_FACING (namespace `track_ids`) with the track id; a humanoid the engine placed
  for a restart (`discontinuity`) has one more TEXT_VIEW_FACING, `placed`, in namespace `discontinuity`.
- `/tf_static`, `tf2_msgs/msg/TFMessage` once, at the first frame's stamp: `pitch` -> each sensor's name, its pose.

Stamps are game time (seconds since kick-off of the captured clip, not the Unix epoch), the same in
every format: a cloud's header stamp is the frame's sweep start (`Frame.time_s`; a unit's message: its first
point's time), the boxes' the label
time (`Frame.label_time_s`). `BagWriter` takes frames one at a time and writes each as it comes.
"""

from __future__ import annotations

import contextlib
import functools
import io
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import numpy as np
from numpy.typing import NDArray

from simgen import __version__
from simgen.atomic import atomic_directory
from simgen.datasets import livox_msgs
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.frame import Frame, class_names
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import FileRecord, record_file
from simgen.datasets.units import LidarUnit, lidar_units
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError
from simgen.vocab import OFFICIAL_CLASS

if TYPE_CHECKING:
    from simgen.datasets.manifest import Manifest
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor


WORLD_FRAME = "pitch"
ALL_POINTS_TOPIC = "/simgen/points"
BOXES_TOPIC = "/simgen/boxes"
TF_STATIC_TOPIC = "/tf_static"
#: Bytes a frame's messages take besides its points (boxes, keypoints and headers of 25 humanoids: 13.5 KB), rounded up.
FRAME_BYTES = 1 << 17
BAG_BYTES = 1 << 20  # schemas, channels, /tf_static of up to 255 sensors, rounded up
FLOAT32, FLOAT64, UINT8, UINT32, INT32 = 7, 8, 2, 6, 5  # sensor_msgs/PointField datatypes
DATATYPE_NAMES = {FLOAT32: "FLOAT32", FLOAT64: "FLOAT64", UINT8: "UINT8", UINT32: "UINT32", INT32: "INT32"}
#: (name, offset, PointField datatype, numpy type): livox_ros_driver2's 26-byte point, then simgen's fields.
POINT_FIELDS = (
    ("x", 0, FLOAT32, "<f4"),
    ("y", 4, FLOAT32, "<f4"),
    ("z", 8, FLOAT32, "<f4"),
    ("intensity", 12, FLOAT32, "<f4"),
    ("tag", 16, UINT8, "u1"),
    ("line", 17, UINT8, "u1"),
    ("timestamp", 18, FLOAT64, "<f8"),
    ("offset_time", 26, UINT32, "<u4"),
    ("instance_id", 30, INT32, "<i4"),
)


@dataclass(frozen=True)
class PointLayout:
    """A PointCloud2 point: the first `fields` of POINT_FIELDS, packed into `step` bytes; or, with `custom`, Livox's
    `CustomMsg` of that driver package (`livox_msgs`), its points taken from all of POINT_FIELDS."""

    name: str
    fields: int
    step: int
    per_sensor: bool  # a topic per sensor (else one, ALL_POINTS_TOPIC)
    sensor_frame: bool  # points in the sensor's frame (else the pitch frame)
    per_unit: bool = False  # a message per lidar unit (a head: the Mid-100 has three), stamped at its first point
    custom: str | None = None  # the Livox driver package whose CustomMsg carries the points (else PointCloud2)

    @property
    def point_fields(self) -> tuple[tuple[str, int, int, str], ...]:
        return POINT_FIELDS[: self.fields]

    @property
    def dtype(self) -> np.dtype:
        fields = self.point_fields
        return np.dtype({"names": [f[0] for f in fields], "formats": [f[3] for f in fields],
                         "offsets": [f[1] for f in fields], "itemsize": self.step})

    @property
    def msgtype(self) -> str:
        return livox_msgs.custom_msg_type(self.custom) if self.custom else SCHEMAS[0]


SIMGEN_LAYOUT = PointLayout("simgen", 9, 34, per_sensor=True, sensor_frame=False)
LIVOX_LAYOUT = PointLayout("livox", 7, 26, per_sensor=True, sensor_frame=True)  # livox_ros_driver2's LivoxPointXyzrtlt
XYZI_LAYOUT = PointLayout("xyzi", 4, 16, per_sensor=False, sensor_frame=False)
#: livox_ros_driver2's CustomMsg; livox_ros_driver's (v1) 18-byte PointCloud2 (LivoxPointXyzrtl) and its CustomMsg.
LIVOX_CUSTOM_LAYOUT = PointLayout("livox-custom", 9, 34, True, True, per_unit=True, custom=livox_msgs.DRIVER2)
LIVOX_V1_LAYOUT = PointLayout("livox-v1", 6, 18, True, True, per_unit=True)
LIVOX_V1_CUSTOM_LAYOUT = PointLayout("livox-v1-custom", 9, 34, True, True, per_unit=True, custom=livox_msgs.DRIVER1)
LAYOUTS = {layout.name: layout for layout in (SIMGEN_LAYOUT, LIVOX_LAYOUT, XYZI_LAYOUT, LIVOX_CUSTOM_LAYOUT,
                                              LIVOX_V1_LAYOUT, LIVOX_V1_CUSTOM_LAYOUT)}
#: `--topic` and `--frame-id` templates' fields: the sensor's name, the unit (head) in it, the unit's lidar_id.
NAME_FIELDS = ("sensor", "unit", "lidar_id")
UNIT_TOPIC = "/simgen/{sensor}/lidar_{unit}"  # per-unit layouts' default topic


def sensor_units(sensors: Sequence[Sensor]) -> list[LidarUnit]:
    """A unit per sensor, for the layouts with a message per sensor (head 0, lidar_id its sensor id)."""
    return [LidarUnit(sensor, 0, sensor.sensor_id) for sensor in sorted(sensors, key=lambda s: s.sensor_id)]


@dataclass(frozen=True)
class Naming:
    """Topic and frame names of the points, as templates of NAME_FIELDS (None: the layout's default)."""

    topic: str | None = None
    frame_id: str | None = None

    def topic_of(self, layout: PointLayout, unit: LidarUnit) -> str:
        default = UNIT_TOPIC if layout.per_unit else points_topic("{sensor}")
        return _fill(self.topic or default, "--topic", unit)

    def frame_of(self, layout: PointLayout, unit: LidarUnit) -> str:
        if not layout.sensor_frame:
            return WORLD_FRAME
        return _fill(self.frame_id or "{sensor}", "--frame-id", unit)


def _fill(template: str, option: str, unit: LidarUnit) -> str:
    try:
        return template.format(sensor=unit.sensor.name, unit=unit.head, lidar_id=unit.lidar_id)
    except (KeyError, IndexError, ValueError) as error:
        fields = ", ".join(f"{{{f}}}" for f in NAME_FIELDS)
        raise UserError(f"{option} {template!r}: not a name template ({error}); its fields are {fields}") from None


def check_naming(naming: Naming, layout: PointLayout, sensors: Sequence[Sensor]) -> None:
    """Refuse names the layout cannot take: a frame for pitch-frame points, topics shared by units of PointCloud2s
    that could not tell them apart (Livox's CustomMsg can: its lidar_id), one frame for sensors at different poses."""
    if naming.frame_id is not None and not layout.sensor_frame:
        raise UserError(f"--frame-id: the {layout.name} layout's points are in the {WORLD_FRAME} frame")
    if naming.topic is not None and not layout.per_sensor:
        raise UserError(f"--topic: the {layout.name} layout has one points topic, {ALL_POINTS_TOPIC}")
    if not layout.per_sensor:
        return
    units = lidar_units(sensors) if layout.per_unit else sensor_units(sensors)
    topics = [naming.topic_of(layout, u) for u in units]
    if not layout.custom and len(set(topics)) < len(topics):
        raise UserError(f"--topic {naming.topic!r} gives units the same topic; the {layout.name} layout's points carry "
                        "no lidar id: add {unit} or {lidar_id}, or use a CustomMsg layout")
    frames: dict[str, int] = {}
    for unit in units if layout.sensor_frame else []:
        frame = naming.frame_of(layout, unit)
        if frames.setdefault(frame, unit.sensor.sensor_id) != unit.sensor.sensor_id:
            raise UserError(f"--frame-id {naming.frame_id!r} names two sensors' frames {frame!r}; add {{sensor}}")


BOX_COLOURS = {OFFICIAL_CLASS: (1.0, 0.9, 0.0, 0.6)}  # RGBA; players white
PLAYER_COLOUR = (1.0, 1.0, 1.0, 0.6)
TEXT_HEIGHT_M = 0.5
DISCONTINUITY_NAMESPACE = "discontinuity"  # markers of boxes whose humanoid the engine placed
SCHEMAS = ("sensor_msgs/msg/PointCloud2", "visualization_msgs/msg/MarkerArray", "tf2_msgs/msg/TFMessage")


#: What each topic's publisher offers, (keep-last depth, durability), all reliable: points as
#: livox_ros_driver2 publishes a lidar's PointCloud2 (rclcpp's default reliable, volatile, keep last 64),
#: boxes as an rclcpp publisher of depth 10, and the static transforms as tf2_ros's
#: StaticTransformBroadcaster (transient local, keep last 1), so that RViz and tf2, which subscribe to
#: /tf_static transient local, get them from `ros2 bag play`.
QOS_PROFILES = {"points": (64, "VOLATILE"), BOXES_TOPIC: (10, "VOLATILE"), TF_STATIC_TOPIC: (1, "TRANSIENT_LOCAL")}
#: rosbag2's bag format version: 8 writes the QoS profiles with integer enums, which every rosbag2 reads.
BAG_VERSION = 8


def offered_qos(topic: str):
    """`topic`'s publisher profile as rosbags' `Qos`, which its writer stores in the channel and metadata.yaml."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    depth, durability = QOS_PROFILES.get(topic, QOS_PROFILES["points"])
    never = QosTime(0, 0)  # deadline, lifespan and lease 0: rmw's default, none
    return Qos(QosHistory.KEEP_LAST, depth, QosReliability.RELIABLE, QosDurability[durability], never, never,
               QosLiveliness.AUTOMATIC, never, False)


def points_topic(sensor_name: str) -> str:
    return f"/simgen/{sensor_name}/points"


def nanoseconds(seconds: float) -> int:
    return round(seconds * 1e9)


def _types():
    """The message classes of rosbags' typestore, by ROS type name."""
    return livox_msgs.typestore().types


def _stamp(ns: int):
    return _types()["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header_message(ns: int, frame_id: str = WORLD_FRAME):
    return _types()["std_msgs/msg/Header"](stamp=_stamp(ns), frame_id=frame_id)


def vector_message(x: float = 0.0, y: float = 0.0, z: float = 0.0, kind: str = "geometry_msgs/msg/Vector3"):
    return _types()[kind](x=x, y=y, z=z)


def _quaternion(x: float = 0.0, y: float = 0.0, z: float = 0.0, w: float = 1.0):
    return _types()["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)


def pose_message(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw_rad: float = 0.0):
    position = vector_message(x, y, z, "geometry_msgs/msg/Point")
    orientation = _quaternion(z=float(np.sin(yaw_rad / 2)), w=float(np.cos(yaw_rad / 2)))
    return _types()["geometry_msgs/msg/Pose"](position=position, orientation=orientation)


def marker_message(header, ns: str, id: int, type: int, action: int, pose=None, scale=None,
                   color=(0.0, 0.0, 0.0, 0.0), text: str = "", points: Sequence[tuple[float, float, float]] = ()):
    """A `visualization_msgs/Marker`; what is not given is ROS's default (zeros, empty); `points` (a LINE_STRIP's)
    in metres."""
    types = _types()
    no_bytes = np.zeros(0, np.uint8)
    return types["visualization_msgs/msg/Marker"](
        header=header, ns=ns, id=id, type=type, action=action, pose=pose or pose_message(),
        scale=scale or vector_message(),
        color=types["std_msgs/msg/ColorRGBA"](*color),
        lifetime=types["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
        frame_locked=False, points=[vector_message(*p, kind="geometry_msgs/msg/Point") for p in points], colors=[],
        texture_resource="",
        texture=types["sensor_msgs/msg/CompressedImage"](header=header_message(0, ""), format="", data=no_bytes),
        uv_coordinates=[], text=text, mesh_resource="",
        mesh_file=types["visualization_msgs/msg/MeshFile"](filename="", data=no_bytes),
        mesh_use_embedded_materials=False,
    )


def sensor_quaternion(sensor: Sensor) -> NDArray[np.float64]:
    """(4,) x, y, z, w of a sensor's rotation, sensor frame -> pitch frame."""
    from scipy.spatial.transform import Rotation  # scipy.spatial is slow to import; only bags need it

    return Rotation.from_matrix(sensor.rotation).as_quat()


def cloud_points(frame: Frame, mask: NDArray[np.bool_] | slice, stamp_ns: int, layout: PointLayout = SIMGEN_LAYOUT,
                 sensor: Sensor | None = None) -> NDArray:
    """The frame's points (those of `mask`) as a structured array of `layout`; `sensor`: theirs, for a layout in
    the sensor frame. `tag` is 0: simgen fires one return per shot and makes no noise points."""
    points = np.asarray(frame.points_m, np.float32)[mask]
    if layout.sensor_frame:
        points = ((points.astype(np.float64) - sensor.origin_m) @ sensor.rotation).astype(np.float32)
    out = np.zeros(len(points), layout.dtype)
    out["x"], out["y"], out["z"] = points[:, 0], points[:, 1], points[:, 2]
    out["intensity"] = np.asarray(frame.intensity)[mask]
    if layout.fields > 4:
        out["line"] = frame.line[mask] if frame.line is not None else 0
    if layout.fields > 6:
        offset_ns = np.rint(frame.time_offset_s[mask].astype(np.float64) * 1e9)
        out["timestamp"] = stamp_ns + offset_ns
    if layout.fields > 7:
        out["offset_time"] = offset_ns
        out["instance_id"] = frame.instance_id[mask]
    return out


def unit_points(frame: Frame, mask: NDArray[np.bool_], stamp_ns: int,
                sensor: Sensor) -> tuple[NDArray, NDArray[np.int64]]:
    """A lidar unit's points (those of `mask`): all of POINT_FIELDS in the sensor's frame, and each one's shot
    time (ns)."""
    points = cloud_points(frame, mask, stamp_ns, LIVOX_CUSTOM_LAYOUT, sensor)
    return points, stamp_ns + points["offset_time"].astype(np.int64)


def custom_message(package: str, points: NDArray, shot_ns: NDArray[np.int64], timebase: int, lidar_id: int,
                   frame_id: str):
    """Livox's `CustomMsg` (of driver `package`) of one unit's `points` (`unit_points`): header stamp `timebase`
    (its first point's time), offset_time from it."""
    types = _types()
    point = types[f"{package}/msg/CustomPoint"]
    columns = (shot_ns - timebase, *(points[name] for name in ("x", "y", "z", "intensity", "tag", "line")))
    return types[livox_msgs.custom_msg_type(package)](
        header=header_message(timebase, frame_id), timebase=timebase, point_num=len(points), lidar_id=lidar_id,
        rsvd=np.zeros(3, np.uint8),
        points=[point(offset_time=o, x=x, y=y, z=z, reflectivity=int(r), tag=t, line=line)
                for o, x, y, z, r, t, line in zip(*(c.tolist() for c in columns))],
    )


def cloud_message(points: NDArray, stamp_ns: int, layout: PointLayout = SIMGEN_LAYOUT, frame_id: str = WORLD_FRAME):
    """A `sensor_msgs/PointCloud2` of `points` (a structured array of `layout`)."""
    types = _types()
    return types["sensor_msgs/msg/PointCloud2"](
        header=header_message(stamp_ns, frame_id), height=1, width=len(points),
        fields=[types["sensor_msgs/msg/PointField"](name=name, offset=offset, datatype=kind, count=1)
                for name, offset, kind, _ in layout.point_fields],
        is_bigendian=False, point_step=layout.step, row_step=layout.step * len(points),
        data=np.frombuffer(points.tobytes(), np.uint8), is_dense=True,
    )


def markers_message(frame: Frame, stamp_ns: int):
    """DELETEALL, then a CUBE and a track-id TEXT per box, and a `placed` TEXT per box with a discontinuity."""
    header = header_message(stamp_ns)
    markers = [marker_message(header, "boxes", 0, 0, 3)]
    names = frame.class_name
    ids = frame.track_id if frame.track_id is not None else np.arange(len(frame.boxes))
    placed = frame.discontinuity if frame.discontinuity is not None else np.zeros(len(frame.boxes), bool)
    for box, name, track, jumped in zip(np.asarray(frame.boxes, np.float64), names, ids, placed):
        x, y, z, length, width, height, yaw = box.tolist()
        r, g, b, a = BOX_COLOURS.get(str(name), PLAYER_COLOUR)
        markers.append(marker_message(header, "boxes", int(track), 1, 0, pose_message(x, y, z, yaw),
                                      vector_message(length, width, height), (r, g, b, a), str(name)))
        markers.append(marker_message(header, "track_ids", int(track), 9, 0,
                                      pose_message(x, y, z + height / 2 + TEXT_HEIGHT_M),
                                      vector_message(z=TEXT_HEIGHT_M), (r, g, b, 1.0), str(int(track))))
        if jumped:
            markers.append(marker_message(header, DISCONTINUITY_NAMESPACE, int(track), 9, 0,
                                          pose_message(x, y, z + height / 2 + 2.5 * TEXT_HEIGHT_M),
                                          vector_message(z=TEXT_HEIGHT_M), (1.0, 0.3, 0.3, 1.0), "placed"))
    return marker_array_message(markers)


def marker_array_message(markers: Sequence):
    """A `visualization_msgs/MarkerArray` of `marker_message`s."""
    return _types()["visualization_msgs/msg/MarkerArray"](markers=list(markers))


def tf_static_message(frames: Sequence[tuple[str, Sensor]], stamp_ns: int):
    """`pitch` -> each (frame name, sensor)'s frame: the sensor's pose."""
    types = _types()
    transforms = []
    for name, sensor in frames:
        qx, qy, qz, qw = sensor_quaternion(sensor).tolist()
        x, y, z = (float(v) for v in sensor.pose[:3])
        rotation = _quaternion(qx, qy, qz, qw)
        transform = types["geometry_msgs/msg/Transform"](translation=vector_message(x, y, z), rotation=rotation)
        transforms.append(types["geometry_msgs/msg/TransformStamped"](
            header=header_message(stamp_ns), child_frame_id=name, transform=transform))
    return types["tf2_msgs/msg/TFMessage"](transforms=transforms)


def check_heads(layout: PointLayout, sensors: Sequence[Sensor], frame: Frame) -> None:
    """Refuse a per-unit layout for frames that keep no head per point where a sensor has several units."""
    if layout.per_unit and frame.head is None and any(len(s.heads) > 1 for s in sensors):
        raise UserError(f"--ros2-layout {layout.name}: the frames keep no head per point, which tells a sensor's "
                        "lidar units apart (export a Parquet dataset)")


class BagWriter:
    """A ROS 2 bag, MCAP storage, written frame by frame with rosbags' `Writer`: `add(frame)` for each, then
    `finish()` (or `abort()`).

    `path`: the bag directory to create, which gets `<its name>.mcap` and rosbag2's `metadata.yaml`;
    `sensors`: the dataset's (`Sensor`: name, pose, ...); `layout` the points' layout (XYZI_LAYOUT puts every point
    on one topic, for frames that keep no sensor per point; a per-unit layout a message per lidar unit, which needs
    each point's head where a sensor has several); `naming` the points' topics and frames. Every frame needs its
    `time_s` and `label_time_s`.
    """

    def __init__(self, path: Path, sensors: Sequence[Sensor], layout: PointLayout = SIMGEN_LAYOUT,
                 naming: Naming = Naming()):
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

        check_naming(naming, layout, sensors)
        self.sensors = sorted(sensors, key=lambda s: s.sensor_id)
        self.layout, self.naming = layout, naming
        self.units = lidar_units(self.sensors) if layout.per_unit else sensor_units(self.sensors)
        self.store = livox_msgs.typestore()
        self.bag = Writer(path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        self.bag.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)  # zstd chunks, as MCAP's own writer
        self.bag.set_custom_data("writer", f"simgen {__version__}")
        self.bag.open()
        self.connections = {}
        self.messages = 0

    def write(self, topic: str, msgtype: str, message, stamp_ns: int) -> None:
        """One message of `msgtype` (a typed message of this writer's `store`) on `topic`, its connection made on
        first use."""
        if topic not in self.connections:
            self.connections[topic] = self.bag.add_connection(
                topic, msgtype, typestore=self.store, offered_qos_profiles=[offered_qos(topic)])
        self.bag.write(self.connections[topic], stamp_ns, self.store.serialize_cdr(message, msgtype))
        self.messages += 1

    def _write_tf_static(self, stamp_ns: int) -> None:
        if self.layout.sensor_frame:
            frames = {self.naming.frame_of(self.layout, u): u.sensor for u in self.units}
        else:
            frames = {s.name: s for s in self.sensors}
        self.write(TF_STATIC_TOPIC, SCHEMAS[2], tf_static_message(list(frames.items()), stamp_ns), stamp_ns)

    def add(self, frame: Frame) -> None:
        stamp_ns = nanoseconds(frame.time_s)
        if not self.messages:  # the static transforms at the first frame's stamp: playback starts there
            self._write_tf_static(stamp_ns)
        layout = self.layout
        if layout.per_unit:
            self._add_units(frame, stamp_ns)
        elif layout.per_sensor:
            sensor = np.asarray(frame.sensor)
            for unit in self.units:
                points = cloud_points(frame, sensor == unit.sensor.sensor_id, stamp_ns, layout, unit.sensor)
                message = cloud_message(points, stamp_ns, layout, self.naming.frame_of(layout, unit))
                self.write(self.naming.topic_of(layout, unit), SCHEMAS[0], message, stamp_ns)
        else:
            points = cloud_points(frame, slice(None), stamp_ns, layout)
            self.write(ALL_POINTS_TOPIC, SCHEMAS[0], cloud_message(points, stamp_ns, layout), stamp_ns)
        label_ns = nanoseconds(frame.label_time_s)
        self.write(BOXES_TOPIC, SCHEMAS[1], markers_message(frame, label_ns), label_ns)

    def _add_units(self, frame: Frame, stamp_ns: int) -> None:
        """A message per lidar unit, stamped at its first point (the sweep start if it has none)."""
        layout, sensor = self.layout, np.asarray(frame.sensor)
        check_heads(layout, self.sensors, frame)
        head = np.asarray(frame.head) if frame.head is not None else np.zeros(len(sensor), np.uint8)
        for unit in self.units:
            points, shot_ns = unit_points(frame, (sensor == unit.sensor.sensor_id) & (head == unit.head), stamp_ns,
                                          unit.sensor)
            timebase = int(shot_ns.min()) if len(points) else stamp_ns
            frame_id = self.naming.frame_of(layout, unit)
            if layout.custom:
                message = custom_message(layout.custom, points, shot_ns, timebase, unit.lidar_id, frame_id)
            else:
                packed = np.zeros(len(points), layout.dtype)
                for name in layout.dtype.names:
                    packed[name] = points[name]
                message = cloud_message(packed, timebase, layout, frame_id)
            self.write(self.naming.topic_of(layout, unit), layout.msgtype, message, timebase)

    def finish(self) -> None:
        """Close the MCAP and write `metadata.yaml`."""
        if not self.messages:
            self._write_tf_static(0)
        self.bag.close()

    def abort(self) -> None:
        self.bag.abort()


def labelled_to_frame(frame: LabelledFrame) -> Frame:
    """What the bag needs of a `LabelledFrame`, as the reader's `Frame`."""
    scan, labels = frame.scan, frame.labels
    return Frame(
        clip=frame.clip, index=frame.index, points_m=scan.points_m, intensity=scan.intensity, boxes=labels.boxes,
        class_name=class_names(labels.team), track_id=labels.track_id, time_s=frame.time_s,
        label_time_s=frame.label_time_s, time_offset_s=scan.time_offset_s, sensor=scan.sensor, head=scan.head,
        line=scan.line,
        instance_id=scan.instance_id, discontinuity=labels.discontinuity,
    )


@dataclass(frozen=True)
class BagSummary:
    messages: int
    frames: int


def bag_name(path: Path) -> str:
    """The name of the MCAP in the bag directory `path`: the directory's, less a `.mcap` suffix."""
    return path.name.removesuffix(".mcap") or path.name


def write_bag(path: Path, frames: Iterable[Frame], sensors: Sequence[Sensor], layout: PointLayout = SIMGEN_LAYOUT,
              naming: Naming = Naming()) -> BagSummary:
    """Write `frames` (an iterable of `Frame`, consumed one at a time) as the new bag directory `path`
    (`<bag_name>.mcap` and `metadata.yaml`), atomically."""
    count = 0
    with atomic_directory(path, bag_name(path)) as tmp:
        bag = BagWriter(tmp, sensors, layout, naming)
        try:
            for frame in frames:
                bag.add(frame)
                count += 1
        except BaseException:
            bag.abort()
            raise
        bag.finish()
    return BagSummary(bag.messages, count)


def bag_messages(frames: int, sensors: int) -> int:
    """Messages in a clip's bag: the static transforms, then per frame a cloud per sensor and the boxes."""
    return 1 + frames * (sensors + 1)


def bag_path(clip: str) -> str:
    """A clip's MCAP in an `mcap` dataset: in its bag directory `<clip>/`, beside `metadata.yaml`."""
    return f"{clip}/{clip}.mcap"


def bag_metadata_path(clip: str) -> str:
    return f"{clip}/metadata.yaml"


class McapClipStream:
    """One clip's bag directory, `<clip>/` with `<clip>.mcap` and `metadata.yaml`, written as its frames come (the
    dataset writer's stream for format mcap); the records' rows are its messages. `abort` leaves nothing under
    the final name."""

    def __init__(self, root: Path, clip: str, sensors: Sequence[Sensor]):
        self.root, self.clip = Path(root), clip
        self.root.mkdir(parents=True, exist_ok=True)
        self._directory = contextlib.ExitStack()
        path = self._directory.enter_context(atomic_directory(self.root / clip, clip, replace=True))
        self._bag = BagWriter(path, sensors)

    def add(self, frame: LabelledFrame) -> None:
        self._bag.add(labelled_to_frame(frame))

    def close(self) -> list[FileRecord]:
        self._bag.finish()
        self._directory.close()
        return [record_file(self.root, relative, self._bag.messages)
                for relative in (bag_path(self.clip), bag_metadata_path(self.clip))]

    def abort(self) -> None:
        self._bag.abort()
        self._directory.__exit__(RuntimeError, RuntimeError("aborted"), None)


def read_bag(stream: BinaryIO) -> dict[str, list]:
    """Decoded messages of a bag by topic, in log-time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    topics: dict[str, list] = {}
    reader = make_reader(stream, decoder_factories=[DecoderFactory()])
    for _, channel, _, message in reader.iter_decoded_messages(log_time_order=True):
        topics.setdefault(channel.topic, []).append(message)
    return topics


def cloud_array(message, layout: PointLayout = SIMGEN_LAYOUT) -> NDArray:
    """A PointCloud2 message of `layout` as a structured array."""
    fields = [(f.name, f.offset, f.datatype) for f in message.fields]
    if message.point_step != layout.step or fields != [f[:3] for f in layout.point_fields]:
        raise ValueError(f"not the {layout.name} PointCloud2 layout")
    return np.frombuffer(bytes(message.data), layout.dtype, count=message.width)


def boxes_of(message) -> tuple[NDArray[np.float32], NDArray[np.str_], NDArray[np.int32], NDArray[np.bool_]]:
    """(H, 7) boxes, class names, track ids and discontinuity flags of a MarkerArray's CUBE markers."""
    cubes = [m for m in message.markers if m.ns == "boxes" and m.type == 1 and m.action == 0]
    boxes = np.array(
        [[m.pose.position.x, m.pose.position.y, m.pose.position.z, m.scale.x, m.scale.y, m.scale.z,
          2 * np.arctan2(m.pose.orientation.z, m.pose.orientation.w)] for m in cubes], np.float64,
    ).reshape(-1, 7)
    boxes[:, 6] = np.pi - np.mod(np.pi - boxes[:, 6], 2 * np.pi)  # (-pi, pi]
    ids = np.array([m.id for m in cubes], np.int32)
    placed = [m.id for m in message.markers if m.ns == DISCONTINUITY_NAMESPACE and m.action == 0]
    return boxes.astype(np.float32), np.array([m.text for m in cubes], np.str_), ids, np.isin(ids, placed)


def check_declared_size(data: bytes, path: Path, points: int, frames: int) -> None:
    """Before anything is decompressed: the bag's chunks declare at most what `frames` frames holding `points`
    points in all take (`SIMGEN_LAYOUT`'s bytes a point, `FRAME_BYTES` a frame besides, `BAG_BYTES` once)."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    most = points * SIMGEN_LAYOUT.step + frames * FRAME_BYTES + BAG_BYTES
    declared = 0
    for record in StreamReader(io.BytesIO(data), emit_chunks=True).records:
        declared += record.uncompressed_size if isinstance(record, Chunk) else 0
        if declared > most:
            raise UserError(f"{path}: its chunks declare over {most:,} bytes, more than {points:,} points in "
                            f"{frames:,} frames take (manifest.json)")


class BagReader:
    """Frames of an `mcap` dataset (points grouped by sensor, in sensor order)."""

    def __init__(self, files: DatasetFiles, manifest: Manifest):
        self.files = files
        self.sensors = sorted(manifest.sensors, key=lambda s: s.sensor_id)
        self.clips = {entry.clip: entry for entry in manifest.clips}
        self._clip = functools.lru_cache(maxsize=2)(self._load)

    def _load(self, clip: str) -> dict[str, list]:
        relative = bag_path(clip)
        data = self.files.read(relative)
        try:
            check_declared_size(data, self.files.root / relative, self.clips[clip].points, self.clips[clip].frames)
            return read_bag(io.BytesIO(data))
        except UserError:
            raise
        except Exception as error:  # noqa: BLE001  the mcap readers raise their own error types for a damaged file
            problem = f"{error.__class__.__name__}: {error}"
            raise UserError(f"{self.files.root / relative}: not a readable MCAP bag ({problem})") from None

    def frame(self, clip: str, index: int) -> Frame:
        topics = self._clip(clip)
        clouds = [(info.sensor_id, topics.get(points_topic(info.name), [])) for info in self.sensors]
        arrays = [(sensor, cloud_array(messages[index])) for sensor, messages in clouds]
        points = np.concatenate([a for _, a in arrays]) if arrays else np.zeros(0, SIMGEN_LAYOUT.dtype)
        header = clouds[0][1][index].header.stamp
        stamp_ns = header.sec * 1_000_000_000 + header.nanosec
        markers = topics[BOXES_TOPIC][index]
        label = markers.markers[0].header.stamp
        boxes, names, ids, placed = boxes_of(markers)
        return Frame(
            clip=clip, index=index,
            points_m=np.ascontiguousarray(np.stack([points["x"], points["y"], points["z"]], axis=1)),
            intensity=points["intensity"].astype(np.uint8), boxes=boxes, class_name=names, track_id=ids,
            discontinuity=placed,
            time_s=stamp_ns / 1e9, label_time_s=(label.sec * 1_000_000_000 + label.nanosec) / 1e9,
            time_offset_s=(points["offset_time"] / 1e9).astype(np.float32),
            sensor=np.concatenate([np.full(len(a), s, np.uint8) for s, a in arrays]) if arrays else None,
            line=points["line"].copy(), instance_id=points["instance_id"].copy(),
        )


def card_lines() -> list[str]:
    """The dataset card's layout section for an `mcap` dataset."""
    meaning = ["metres, pitch frame", "", "", "reflectivity 0-255", "0 (no return flags)",
               "laser of the head that fired", "shot time, ns (header stamp + offset_time)",
               "ns since the header stamp", "track id, 1000 ball, -1 none"]
    rows = [f"| `{name}` | {offset} | {DATATYPE_NAMES[kind]} | {text} |"
            for (name, offset, kind, _), text in zip(POINT_FIELDS, meaning)]
    qos = {topic: durability.lower() for topic, (_, durability) in QOS_PROFILES.items()}
    return [
        "A ROS 2 bag per clip, the rosbag2 directory `<clip id>/`: `<clip id>.mcap` (CDR, ROS 2 Humble message",
        "definitions in the file) and `metadata.yaml`. Open the directory with `ros2 bag info`, `ros2 bag play` or",
        "`rosbags`, the `.mcap` with Foxglove or the `mcap` Python package. Stamps are game time, not the epoch:",
        "a cloud's header stamp is its frame's sweep start, the boxes' the label time (the middle of the sweep).",
        "",
        f"- `{points_topic('<sensor name>')}`: `sensor_msgs/msg/PointCloud2` per sensor and frame (empty ones too),",
        f"  frame `{WORLD_FRAME}`, {SIMGEN_LAYOUT.step}-byte little-endian points; the first {LIVOX_LAYOUT.step} "
        "bytes are",
        "  livox_ros_driver2's point (`LivoxPointXyzrtlt`), but in the pitch frame, not the sensor's; read the fields "
        "by",
        "  name. `simgen export --ros2-layout livox` writes the driver's exact 26-byte point in each sensor's frame;",
        "  `livox-custom`, `livox-v1` and `livox-v1-custom` a message per lidar unit as Livox's drivers publish them.",
        "",
        "| field | offset | type | meaning |",
        "| --- | --- | --- | --- |",
        *rows,
        "",
        f"- `{BOXES_TOPIC}`: `visualization_msgs/msg/MarkerArray` per frame at the label time: DELETEALL, then per",
        "  humanoid a CUBE (namespace `boxes`, id = track id, `text` = class) and a TEXT_VIEW_FACING track id; a",
        "  humanoid the engine placed for a restart (`discontinuity`) also a TEXT_VIEW_FACING `placed` (namespace",
        f"  `{DISCONTINUITY_NAMESPACE}`, id = track id).",
        f"- `{TF_STATIC_TOPIC}`: `tf2_msgs/msg/TFMessage` at the first frame's stamp, `{WORLD_FRAME}` -> each "
        "sensor's name (its pose).",
        "",
        "Each channel carries rosbag2's `offered_qos_profiles` metadata, which `ros2 bag play` offers again: all "
        "reliable;",
        f"points {qos['points']} (keep last {QOS_PROFILES['points'][0]}, as livox_ros_driver2 publishes), boxes"
        f" {qos[BOXES_TOPIC]}, `{TF_STATIC_TOPIC}` {qos[TF_STATIC_TOPIC].replace('_', ' ')} (keep last 1, as tf2's "
        "static",
        "broadcaster), so RViz and tf2 get the sensor poses whenever they subscribe.",
    ]


class Mcap(DatasetFormat):
    name = "mcap"
    carries = Carries(track_ids=True, point_fields=True, point_counts=False)

    def stream(self, root, clip, clip_index, sensors):
        return McapClipStream(root, clip, sensors)

    def reader(self, files, manifest):
        return BagReader(files, manifest)

    def clip_files(self, entry: ClipEntry) -> set[str]:
        return {bag_path(entry.clip), bag_metadata_path(entry.clip)}

    def listed_rows_problem(self, entry: ClipEntry, listed: Mapping[str, FileRecord], sensors: int) -> str | None:
        rows = listed[bag_path(entry.clip)].rows
        if rows == bag_messages(entry.frames, sensors):
            return None
        return f"clip {entry.clip} lists {entry.frames} frames, its bag {rows} messages"

    def card_layout(self, manifest: Manifest) -> list[str]:
        return card_lines()

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        bag = str(root / bag_path(entry.clip))
        return lambda k, i: (bag, first_row[k] + i)  # box of the clip, from 0, in the /simgen/boxes messages


FORMAT = Mcap()
