"""Where `track` reads its frames, one at a time in time order: a dataset's clips, or a ROS 2 MCAP bag of points.

Nothing here reads ahead of the frame asked for: `Window` keeps the last TRACKLET_FRAMES frames of a clip
for the detector's windows (t-2..t), and a bag's frame is handed on as soon as every points topic has
delivered its cloud of that stamp. A bag in simgen's layout has its points in the pitch frame; in
livox_ros_driver2's (`--ros2-layout livox`) in each sensor's frame (`frame_id`), posed by `/tf_static`.
A bag's boxes (`/simgen/boxes`, as simgen writes them) are its labels, for the metrics.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.frame import Frame
from simgen.errors import UserError
from train.config import TRACKLET_FRAMES

POINTCLOUD2 = "sensor_msgs/msg/PointCloud2"


class Window:
    """The newest TRACKLET_FRAMES frames read of a clip, as `train.data.load_sample` asks for them
    (`root`, `sequence`); `read` fetches a frame not kept (a dataset's), or None (a bag's: pushed with `add`)."""

    def __init__(self, root: Path, read: Callable[[str, int], Frame] | None) -> None:
        self.root, self.read = root, read
        self.kept: dict[tuple[str, int], Frame] = {}

    def add(self, frame: Frame) -> Frame:
        self.kept[(frame.clip, frame.index)] = frame
        newest = max(index for clip, index in self.kept if clip == frame.clip)
        self.kept = {k: v for k, v in self.kept.items() if k[0] == frame.clip and k[1] > newest - TRACKLET_FRAMES}
        return frame

    def frame(self, clip: str, index: int) -> Frame:
        if (clip, index) not in self.kept:
            if self.read is None:
                raise UserError(f"{self.root}: frame {index} of {clip} is no longer (or not yet) held")
            self.add(self.read(clip, index))
        return self.kept[(clip, index)]

    def sequence(self, clip: str, index: int, length: int) -> list[Frame]:
        if index - length + 1 < 0:
            raise UserError(f"{self.root}: clip {clip} has no {length} frames ending at frame {index}")
        return [self.frame(clip, i) for i in range(index - length + 1, index + 1)]


@dataclass(frozen=True)
class Labels:
    """One frame's labelled boxes (H, 7), class names, track ids and discontinuity flags."""

    boxes: NDArray[np.float32]
    class_name: NDArray[np.str_]
    track_id: NDArray[np.int32]
    placed: NDArray[np.bool_]


def frame_labels(frame: Frame) -> Labels | None:
    """A dataset frame's labels; None where the format keeps no track ids."""
    if frame.track_id is None:
        return None
    placed = frame.discontinuity if frame.discontinuity is not None else np.zeros(len(frame.boxes), bool)
    return Labels(frame.boxes, frame.class_name, frame.track_id, placed)


def _rotation(quaternion) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([quaternion.x, quaternion.y, quaternion.z, quaternion.w]).as_matrix()


class BagFrames:
    """A ROS 2 MCAP bag's point clouds as frames (index k: the k-th stamp), read one message at a time.

    `labels[k]`: the bag's boxes at frame k (simgen's `/simgen/boxes`), filled as they come, after the frame.
    """

    def __init__(self, path: Path, layout_name: str) -> None:
        from mcap.exceptions import McapError
        from mcap.reader import make_reader

        from simgen.datasets.formats.mcap import LAYOUTS, bag_name

        self.clip = bag_name(path) if path.is_dir() else path.stem
        self.path = path / f"{self.clip}.mcap" if path.is_dir() else path  # a rosbag2 directory, or its MCAP
        self.layout = LAYOUTS[layout_name]
        self.labels: dict[int, Labels] = {}
        try:
            with open(self.path, "rb") as stream:
                summary = make_reader(stream).get_summary()
        except (OSError, McapError, ValueError) as error:
            raise UserError(f"--bag {path}: not a readable MCAP file ({error.__class__.__name__})") from None
        if summary is None:
            raise UserError(f"--bag {path}: an MCAP file without a summary (not finished?)")
        schemas = {i: s.name for i, s in summary.schemas.items()}
        clouds = {c.topic: i for i, c in summary.channels.items() if schemas.get(c.schema_id) == POINTCLOUD2}
        self.topics = sorted(clouds)
        if not self.topics:
            raise UserError(f"--bag {path}: no points (no sensor_msgs/msg/PointCloud2 topic)")
        counts = summary.statistics.channel_message_counts if summary.statistics is not None else {}
        self.count = min((counts[i] for i in clouds.values() if i in counts), default=None)  # frames, if the bag says

    def frames(self) -> Iterator[Frame]:
        """Frames in stamp order, each as soon as every points topic has delivered its cloud of that stamp."""
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        from simgen.datasets.formats.mcap import BOXES_TOPIC, TF_STATIC_TOPIC, boxes_of, cloud_array

        poses: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
        pending: dict[str, NDArray] = {}
        index, stamp = 0, None
        with open(self.path, "rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            for _, channel, _, message in reader.iter_decoded_messages(log_time_order=True):
                if channel.topic == TF_STATIC_TOPIC:
                    for t in message.transforms:
                        move = t.transform.translation
                        poses[t.child_frame_id] = (_rotation(t.transform.rotation), np.array([move.x, move.y, move.z]))
                elif channel.topic == BOXES_TOPIC:
                    boxes, names, ids, placed = boxes_of(message)
                    self.labels[index - 1] = Labels(boxes, names, ids, placed)
                elif channel.topic in self.topics:
                    try:
                        cloud = cloud_array(message, self.layout)
                    except ValueError:
                        raise UserError(f"--bag {self.path}: {channel.topic} is not in the {self.layout.name} "
                                        "point layout (--ros2-layout)") from None
                    pending[channel.topic] = self._in_pitch(cloud, message.header.frame_id, poses, channel.topic)
                    stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
                    if len(pending) == len(self.topics):
                        yield self._frame(index, stamp, [pending[t] for t in self.topics])
                        pending, index = {}, index + 1

    def _in_pitch(self, cloud: NDArray, frame_id: str, poses: dict, topic: str) -> NDArray:
        """(P, 4) x, y, z in the pitch frame and intensity."""
        xyz = np.stack([cloud["x"], cloud["y"], cloud["z"]], axis=1).astype(np.float64)
        if self.layout.sensor_frame:
            if frame_id not in poses:
                raise UserError(f"--bag {self.path}: {topic}'s frame {frame_id!r} has no pose on /tf_static")
            rotation, origin = poses[frame_id]
            xyz = xyz @ rotation.T + origin
        return np.column_stack([xyz, cloud["intensity"]]).astype(np.float32)

    def _frame(self, index: int, stamp: float, clouds: list[NDArray]) -> Frame:
        points = np.concatenate(clouds) if clouds else np.zeros((0, 4), np.float32)
        if not np.isfinite(points).all():
            raise UserError(f"--bag {self.path}: frame {index} has a NaN or infinite point")
        empty = np.zeros((0, 7), np.float32)
        return Frame(self.clip, index, np.ascontiguousarray(points[:, :3]), points[:, 3].clip(0, 255).astype(np.uint8),
                     empty, np.zeros(0, np.str_), np.zeros(0, np.int32), time_s=stamp, label_time_s=stamp)
