"""`simgen export`: a clip of any simgen dataset as a ROS 2 bag in MCAP."""

from __future__ import annotations

from pathlib import Path

from simgen.atomic import check_new
from simgen.commands.arguments import add_command, add_dataset_argument, frame_range
from simgen.errors import UserError

EXPORT_FORMATS = ("mcap",)
ROS2_LAYOUTS = ("simgen", "livox")


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "export",
        "a clip of a dataset as a ROS 2 bag (MCAP)",
        "Write the frames A:B of a clip of any simgen dataset as one ROS 2 bag in MCAP: per sensor a "
        "sensor_msgs/PointCloud2 per frame, the boxes as a visualization_msgs/MarkerArray with track ids at the "
        "label time, and the sensor poses on /tf_static (transient local, as tf2 publishes them); stamps are "
        "game time, as in every simgen output, and each channel carries rosbag2's offered QoS profiles. Points "
        "(--ros2-layout): `simgen` (default) in the pitch frame, livox_ros_driver2's point (x, y, z, intensity, "
        "tag, line = head, timestamp) plus offset_time and instance_id; `livox` exactly the driver's 26-byte "
        "point in each sensor's frame. Datasets that keep no sensor per point (KITTI, OpenPCDet) give one "
        "/simgen/points topic of x, y, z, intensity, and the command says what they cannot carry. Play it with "
        "`ros2 bag play FILE`, open it in Foxglove, or read it with rosbags or mcap.",
    )
    add_dataset_argument(parser)
    parser.add_argument("--format", choices=EXPORT_FORMATS, default="mcap", help="output format (default mcap)")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR",
        help="bag directory to create, as `ros2 bag record -o DIR` does: DIR/<name>.mcap and rosbag2's metadata.yaml",
    )
    parser.add_argument("--clip", help="clip id (default: the first clip)")
    parser.add_argument("--frames", default=":", metavar="A:B", help="frames A to B-1 (Python slice; default all)")
    parser.add_argument(
        "--ros2-layout",
        choices=ROS2_LAYOUTS,
        default="simgen",
        help="PointCloud2 points: simgen (pitch frame, 34 bytes, default) or livox (livox_ros_driver2's "
        "26 bytes, sensor frame)",
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from tqdm import tqdm

    from simgen.datasets import open_dataset
    from simgen.datasets.formats import formats_where
    from simgen.datasets.ros2_bag import ALL_POINTS_TOPIC, LAYOUTS, XYZI_LAYOUT, bag_name, write_bag

    check_new(args.output)
    dataset = open_dataset(args.dataset)
    clip = args.clip if args.clip is not None else dataset.clips[0]
    frames = frame_range(args.frames, dataset.num_frames(clip))
    layout = LAYOUTS[args.ros2_layout]
    if not dataset.plugin.carries.point_fields:
        if args.ros2_layout == "livox":
            per_point = formats_where(lambda f: f.carries.point_fields)
            raise UserError(f"--ros2-layout livox: a {dataset.format} dataset keeps no sensor, head or time per point "
                            f"(export a {' or '.join(per_point)} dataset)")
        layout = XYZI_LAYOUT
        ids = "" if dataset.plugin.carries.track_ids else "; no track ids: marker ids number each frame's boxes"
        print(f"{args.output}: {dataset.format} keeps no sensor, head, time or instance per point: x, y, z, intensity "
              f"on one topic, {ALL_POINTS_TOPIC}{ids}")
    progress = tqdm(frames, unit="frame", desc=f"{clip} -> {args.output.name}", dynamic_ncols=True)
    summary = write_bag(args.output, (dataset.frame(clip, i) for i in progress), list(dataset.manifest.sensors), layout)
    print(
        f"{args.output}: {summary.frames} frames of {clip}, {summary.messages} messages (ROS 2, MCAP, {layout.name} "
        f"points), in {bag_name(args.output)}.mcap and metadata.yaml"
    )
    return 0
