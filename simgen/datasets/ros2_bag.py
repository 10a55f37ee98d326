"""A clip as a ROS 2 bag in MCAP (`mcap` + `mcap-ros2-support`, no ROS install), as Livox users record theirs.

The mcap, mcap-ros2-support and rosbags packages are imported only by the functions that write or read a
bag, so that reading a dataset of another format (or training on one) does not need them.

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
- `/simgen/boxes`, `visualization_msgs/msg/MarkerArray` per frame: DELETEALL, then per humanoid a
  CUBE (namespace `boxes`, marker id = track id, `text` the class, which RViz does not draw on a
  cube) and a TEXT_VIEW_FACING (namespace `track_ids`) with the track id; a humanoid the engine placed
  for a restart (`discontinuity`) has one more TEXT_VIEW_FACING, `placed`, in namespace `discontinuity`.
- `/tf_static`, `tf2_msgs/msg/TFMessage` once, at the first frame's stamp: `pitch` -> each sensor's name, its pose.

Stamps are game time (seconds since kick-off of the captured clip, not the Unix epoch), the same in
every format: a cloud's header stamp is the frame's sweep start (`Frame.time_s`), the boxes' the label
time (`Frame.label_time_s`). `BagWriter` takes frames one at a time and writes each as it comes.
"""

from __future__ import annotations

import contextlib
import functools
import io
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import numpy as np
from numpy.typing import NDArray

from simgen import __version__
from simgen.atomic import atomic_path
from simgen.datasets.frame import Frame, class_names
from simgen.datasets.records import FileRecord, record_file
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError
from simgen.vocab import OFFICIAL_CLASS

if TYPE_CHECKING:
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor

WORLD_FRAME = "pitch"
ALL_POINTS_TOPIC = "/simgen/points"
BOXES_TOPIC = "/simgen/boxes"
TF_STATIC_TOPIC = "/tf_static"
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
    """A PointCloud2 point: the first `fields` of POINT_FIELDS, packed into `step` bytes."""

    name: str
    fields: int
    step: int
    per_sensor: bool  # a topic per sensor (else one, ALL_POINTS_TOPIC)
    sensor_frame: bool  # points in the sensor's frame (else the pitch frame)

    @property
    def point_fields(self) -> tuple[tuple[str, int, int, str], ...]:
        return POINT_FIELDS[: self.fields]

    @property
    def dtype(self) -> np.dtype:
        fields = self.point_fields
        return np.dtype({"names": [f[0] for f in fields], "formats": [f[3] for f in fields],
                         "offsets": [f[1] for f in fields], "itemsize": self.step})


SIMGEN_LAYOUT = PointLayout("simgen", 9, 34, per_sensor=True, sensor_frame=False)
LIVOX_LAYOUT = PointLayout("livox", 7, 26, per_sensor=True, sensor_frame=True)  # livox_ros_driver2's LivoxPointXyzrtlt
XYZI_LAYOUT = PointLayout("xyzi", 4, 16, per_sensor=False, sensor_frame=False)
LAYOUTS = {layout.name: layout for layout in (SIMGEN_LAYOUT, LIVOX_LAYOUT, XYZI_LAYOUT)}
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


def offered_qos_profiles(topic: str) -> str:
    """The channel metadata value rosbag2 writes for `topic`: its publishers' profiles as YAML (the
    integer enums of rosbag2 before metadata version 9, which every later rosbag2 still reads)."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    from rosbags.rosbag2.metadata import dump_qos_v8

    depth, durability = QOS_PROFILES.get(topic, QOS_PROFILES["points"])
    never = QosTime(0, 0)  # deadline, lifespan and lease 0: rmw's default, none
    profile = Qos(QosHistory.KEEP_LAST, depth, QosReliability.RELIABLE, QosDurability[durability], never, never,
                  QosLiveliness.AUTOMATIC, never, False)
    return dump_qos_v8([profile])


def points_topic(sensor_name: str) -> str:
    return f"/simgen/{sensor_name}/points"


def nanoseconds(seconds: float) -> int:
    return int(round(seconds * 1e9))


def _stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _header(ns: int, frame_id: str = WORLD_FRAME) -> dict:
    return {"stamp": _stamp(ns), "frame_id": frame_id}


def _quaternion_xyzw(yaw_rad: float) -> dict:
    return {"x": 0.0, "y": 0.0, "z": float(np.sin(yaw_rad / 2)), "w": float(np.cos(yaw_rad / 2))}


def sensor_quaternion(sensor: Sensor) -> NDArray[np.float64]:
    """(4,) x, y, z, w of a sensor's rotation, sensor frame -> pitch frame."""
    from scipy.spatial.transform import Rotation  # scipy.spatial is slow to import; only bags need it

    return Rotation.from_matrix(sensor.rotation).as_quat()


def cloud_points(frame: Frame, mask: NDArray[np.bool_] | slice, stamp_ns: int, layout: PointLayout = SIMGEN_LAYOUT,
                 sensor: Sensor | None = None) -> NDArray:
    """The frame's points (those of `mask`) as a structured array of `layout`; `sensor`: theirs, for a layout in
    the sensor frame."""
    points = np.asarray(frame.points_m, np.float32)[mask]
    if layout.sensor_frame:
        points = ((points.astype(np.float64) - sensor.origin_m) @ sensor.rotation).astype(np.float32)
    out = np.zeros(len(points), layout.dtype)
    out["x"], out["y"], out["z"] = points[:, 0], points[:, 1], points[:, 2]
    out["intensity"] = np.asarray(frame.intensity)[mask]
    if layout.fields > 4:
        out["line"] = frame.line[mask] if frame.line is not None else 0
        offset_ns = np.rint(frame.time_offset_s[mask].astype(np.float64) * 1e9)
        out["timestamp"] = stamp_ns + offset_ns
    if layout.fields > 7:
        out["offset_time"] = offset_ns
        out["instance_id"] = frame.instance_id[mask]
    return out


def cloud_message(points: NDArray, stamp_ns: int, layout: PointLayout = SIMGEN_LAYOUT, frame_id: str = WORLD_FRAME) -> dict:
    return {
        "header": _header(stamp_ns, frame_id),
        "height": 1,
        "width": len(points),
        "fields": [{"name": name, "offset": offset, "datatype": kind, "count": 1} for name, offset, kind, _ in layout.point_fields],
        "is_bigendian": False,
        "point_step": layout.step,
        "row_step": layout.step * len(points),
        "data": points.tobytes(),
        "is_dense": True,
    }


def markers_message(frame: Frame, stamp_ns: int) -> dict:
    """DELETEALL, then a CUBE and a track-id TEXT per box, and a `placed` TEXT per box with a discontinuity."""
    header = _header(stamp_ns)
    markers = [{"header": header, "ns": "boxes", "id": 0, "type": 0, "action": 3, "pose": {"orientation": {"w": 1.0}}}]
    names = frame.class_name
    ids = frame.track_id if frame.track_id is not None else np.arange(len(frame.boxes))
    placed = frame.discontinuity if frame.discontinuity is not None else np.zeros(len(frame.boxes), bool)
    for box, name, track, jumped in zip(np.asarray(frame.boxes, np.float64), names, ids, placed):
        x, y, z, length, width, height, yaw = box.tolist()
        r, g, b, a = BOX_COLOURS.get(str(name), PLAYER_COLOUR)
        common = {"header": header, "id": int(track), "action": 0, "frame_locked": False}
        markers.append({
            **common, "ns": "boxes", "type": 1, "text": str(name),
            "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": _quaternion_xyzw(yaw)},
            "scale": {"x": length, "y": width, "z": height}, "color": {"r": r, "g": g, "b": b, "a": a},
        })
        markers.append({
            **common, "ns": "track_ids", "type": 9, "text": str(int(track)),
            "pose": {"position": {"x": x, "y": y, "z": z + height / 2 + TEXT_HEIGHT_M}, "orientation": {"w": 1.0}},
            "scale": {"z": TEXT_HEIGHT_M}, "color": {"r": r, "g": g, "b": b, "a": 1.0},
        })
        if jumped:
            markers.append({
                **common, "ns": DISCONTINUITY_NAMESPACE, "type": 9, "text": "placed",
                "pose": {"position": {"x": x, "y": y, "z": z + height / 2 + 2.5 * TEXT_HEIGHT_M}, "orientation": {"w": 1.0}},
                "scale": {"z": TEXT_HEIGHT_M}, "color": {"r": 1.0, "g": 0.3, "b": 0.3, "a": 1.0},
            })
    return {"markers": markers}


def tf_static_message(sensors: Sequence[Sensor], stamp_ns: int) -> dict:
    transforms = []
    for sensor in sensors:
        qx, qy, qz, qw = sensor_quaternion(sensor).tolist()
        x, y, z = (float(v) for v in sensor.pose[:3])
        transforms.append({
            "header": _header(stamp_ns), "child_frame_id": sensor.name,
            "transform": {"translation": {"x": x, "y": y, "z": z}, "rotation": {"x": qx, "y": qy, "z": qz, "w": qw}},
        })
    return {"transforms": transforms}


class BagWriter:
    """A ROS 2 MCAP bag written frame by frame: `add(frame)` for each, then `finish()`.

    `sensors`: the dataset's (`Sensor`: name, pose, ...); `layout` the points'
    PointCloud2 layout (XYZI_LAYOUT puts every point on one topic, for frames that keep no sensor per point).
    Every frame needs its `time_s` and `label_time_s`.
    """

    def __init__(self, stream: BinaryIO, sensors: Sequence[Sensor], layout: PointLayout = SIMGEN_LAYOUT):
        from mcap.well_known import SchemaEncoding
        from mcap.writer import Writer
        from mcap_ros2._dynamic import serialize_dynamic  # mcap-ros2-support's CDR encoder (its Writer cannot give channels metadata)
        from rosbags.typesys import Stores, get_typestore

        typestore = get_typestore(Stores.ROS2_HUMBLE)
        self.writer = Writer(stream)
        self.writer.start(profile="ros2", library=f"simgen {__version__}")
        self.schemas, self.encoders, self.channels = {}, {}, {}
        for name in SCHEMAS:
            text = typestore.generate_msgdef(name, ros_version=2)[0]
            self.schemas[name] = self.writer.register_schema(name, SchemaEncoding.ROS2, text.encode())
            self.encoders[name] = serialize_dynamic(name, text)[name]
        self.sensors = sorted(sensors, key=lambda s: s.sensor_id)
        self.layout = layout
        self.messages = 0

    def write(self, topic: str, schema: str, message: dict, stamp_ns: int) -> None:
        """One message of `schema` (one of SCHEMAS) on `topic`, its channel registered on first use."""
        if topic not in self.channels:
            self.channels[topic] = self.writer.register_channel(
                topic, "cdr", self.schemas[schema], {"offered_qos_profiles": offered_qos_profiles(topic)}
            )
        data = self.encoders[schema](message)
        self.writer.add_message(self.channels[topic], log_time=stamp_ns, data=data, publish_time=stamp_ns, sequence=self.messages)
        self.messages += 1

    def _write_tf_static(self, stamp_ns: int) -> None:
        self.write(TF_STATIC_TOPIC, SCHEMAS[2], tf_static_message(self.sensors, stamp_ns), stamp_ns)

    def add(self, frame: Frame) -> None:
        stamp_ns = nanoseconds(frame.time_s)
        if not self.messages:  # the static transforms at the first frame's stamp: playback starts there
            self._write_tf_static(stamp_ns)
        if self.layout.per_sensor:
            sensor = np.asarray(frame.sensor)
            for info in self.sensors:
                frame_id = info.name if self.layout.sensor_frame else WORLD_FRAME
                points = cloud_points(frame, sensor == info.sensor_id, stamp_ns, self.layout, info)
                self.write(points_topic(info.name), SCHEMAS[0], cloud_message(points, stamp_ns, self.layout, frame_id), stamp_ns)
        else:
            points = cloud_points(frame, slice(None), stamp_ns, self.layout)
            self.write(ALL_POINTS_TOPIC, SCHEMAS[0], cloud_message(points, stamp_ns, self.layout), stamp_ns)
        label_ns = nanoseconds(frame.label_time_s)
        self.write(BOXES_TOPIC, SCHEMAS[1], markers_message(frame, label_ns), label_ns)

    def finish(self) -> None:
        if not self.messages:
            self._write_tf_static(0)
        self.writer.finish()


def labelled_to_frame(frame: LabelledFrame) -> Frame:
    """What the bag needs of a `LabelledFrame`, as the reader's `Frame`."""
    scan, labels = frame.scan, frame.labels
    return Frame(
        clip=frame.clip, index=frame.index, points_m=scan.points_m, intensity=scan.intensity, boxes=labels.boxes,
        class_name=class_names(labels.team), track_id=labels.track_id, time_s=frame.time_s,
        label_time_s=frame.label_time_s, time_offset_s=scan.time_offset_s, sensor=scan.sensor, head=scan.head, line=scan.line,
        instance_id=scan.instance_id, discontinuity=labels.discontinuity,
    )


@dataclass(frozen=True)
class BagSummary:
    messages: int
    frames: int


def write_bag(path: Path, frames: Iterable[Frame], sensors: Sequence[Sensor], layout: PointLayout = SIMGEN_LAYOUT) -> BagSummary:
    """Write `frames` (an iterable of `Frame`, consumed one at a time) to `path` atomically."""
    count = 0
    with atomic_path(path) as tmp, tmp.open("wb") as stream:
        bag = BagWriter(stream, sensors, layout)
        for frame in frames:
            bag.add(frame)
            count += 1
        bag.finish()
    return BagSummary(bag.messages, count)


def bag_messages(frames: int, sensors: int) -> int:
    """Messages in a clip's bag: the static transforms, then per frame a cloud per sensor and the boxes."""
    return 1 + frames * (sensors + 1)


def bag_path(clip: str) -> str:
    return f"{clip}.mcap"


class McapClipStream:
    """One clip's bag, `<clip>.mcap`, written as its frames come (the dataset writer's stream for
    format mcap); its record's rows are its messages. `abort` leaves no file under the final name."""

    def __init__(self, root: Path, clip: str, sensors: Sequence[Sensor]):
        self.root, self.relative = Path(root), bag_path(clip)
        path = self.root / self.relative
        path.parent.mkdir(parents=True, exist_ok=True)
        self._files = contextlib.ExitStack()
        stream = self._files.enter_context(self._files.enter_context(atomic_path(path)).open("wb"))
        self._bag = BagWriter(stream, sensors)

    def add(self, frame: LabelledFrame) -> None:
        self._bag.add(labelled_to_frame(frame))

    def close(self) -> list[FileRecord]:
        self._bag.finish()
        self._files.close()
        return [record_file(self.root, self.relative, self._bag.messages)]

    def abort(self) -> None:
        self._files.__exit__(RuntimeError, RuntimeError("aborted"), None)


def read_bag(stream: BinaryIO) -> dict[str, list]:
    """Decoded messages of a bag by topic, in log-time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    topics: dict[str, list] = {}
    for _, channel, _, message in make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages(log_time_order=True):
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


class BagReader:
    """Frames of an `mcap` dataset (points grouped by sensor, in sensor order)."""

    def __init__(self, files: DatasetFiles, sensors: Sequence[Sensor]):
        self.files = files
        self.sensors = sorted(sensors, key=lambda s: s.sensor_id)
        self._clip = functools.lru_cache(maxsize=2)(self._load)

    def _load(self, clip: str) -> dict[str, list]:
        relative = bag_path(clip)
        data = self.files.read(relative)
        try:
            return read_bag(io.BytesIO(data))
        except Exception as error:  # the mcap readers raise their own error types for a damaged file
            raise UserError(f"{self.files.root / relative}: not a readable MCAP bag ({error.__class__.__name__}: {error})") from None

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
            intensity=points["intensity"].astype(np.uint8), boxes=boxes, class_name=names, track_id=ids, discontinuity=placed,
            time_s=stamp_ns / 1e9, label_time_s=(label.sec * 1_000_000_000 + label.nanosec) / 1e9,
            time_offset_s=(points["offset_time"] / 1e9).astype(np.float32),
            sensor=np.concatenate([np.full(len(a), s, np.uint8) for s, a in arrays]) if arrays else None,
            line=points["line"].copy(), instance_id=points["instance_id"].copy(),
        )


def card_lines() -> list[str]:
    """The dataset card's layout section for an `mcap` dataset."""
    meaning = ["metres, pitch frame", "", "", "reflectivity 0-255", "0 (no return flags)", "laser of the head that fired",
               "shot time, ns (header stamp + offset_time)", "ns since the header stamp", "track id, 1000 ball, -1 none"]
    rows = [f"| `{name}` | {offset} | {DATATYPE_NAMES[kind]} | {text} |" for (name, offset, kind, _), text in zip(POINT_FIELDS, meaning)]
    qos = {topic: durability.lower() for topic, (_, durability) in QOS_PROFILES.items()}
    return [
        "A ROS 2 bag in MCAP per clip, `<clip id>.mcap` (CDR, ROS 2 Humble message definitions in the file; open it",
        "with Foxglove, `ros2 bag play`, `rosbags` or the `mcap` Python package). Stamps are game time, not the epoch:",
        "a cloud's header stamp is its frame's sweep start, the boxes' the label time (the middle of the sweep).",
        "",
        f"- `{points_topic('<sensor name>')}`: `sensor_msgs/msg/PointCloud2` per sensor and frame (empty ones too),",
        f"  frame `{WORLD_FRAME}`, {SIMGEN_LAYOUT.step}-byte little-endian points; the first {LIVOX_LAYOUT.step} bytes are",
        "  livox_ros_driver2's point (`LivoxPointXyzrtlt`), but in the pitch frame, not the sensor's; read the fields by",
        "  name. `simgen export --ros2-layout livox` writes the driver's exact 26-byte point in each sensor's frame.",
        "",
        "| field | offset | type | meaning |",
        "| --- | --- | --- | --- |",
        *rows,
        "",
        f"- `{BOXES_TOPIC}`: `visualization_msgs/msg/MarkerArray` per frame at the label time: DELETEALL, then per",
        "  humanoid a CUBE (namespace `boxes`, id = track id, `text` = class) and a TEXT_VIEW_FACING track id; a",
        "  humanoid the engine placed for a restart (`discontinuity`) also a TEXT_VIEW_FACING `placed` (namespace",
        f"  `{DISCONTINUITY_NAMESPACE}`, id = track id).",
        f"- `{TF_STATIC_TOPIC}`: `tf2_msgs/msg/TFMessage` at the first frame's stamp, `{WORLD_FRAME}` -> each sensor's name (its pose).",
        "",
        "Each channel carries rosbag2's `offered_qos_profiles` metadata, which `ros2 bag play` offers again: all reliable;",
        f"points {qos['points']} (keep last {QOS_PROFILES['points'][0]}, as livox_ros_driver2 publishes), boxes"
        f" {qos[BOXES_TOPIC]}, `{TF_STATIC_TOPIC}` {qos[TF_STATIC_TOPIC].replace('_', ' ')} (keep last 1, as tf2's static",
        "broadcaster), so RViz and tf2 get the sensor poses whenever they subscribe.",
    ]
