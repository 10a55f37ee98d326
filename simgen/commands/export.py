"""`simgen export`: a clip of any simgen dataset as a ROS 2 bag in MCAP."""

from __future__ import annotations

from pathlib import Path

from simgen.commands.arguments import add_command, add_dataset_argument, frame_range
from simgen.errors import UserError

EXPORT_FORMATS = ("mcap",)


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "export",
        "a clip of a dataset as a ROS 2 bag (MCAP)",
        "Write the frames A:B of a clip of any simgen dataset as one ROS 2 bag in MCAP: per sensor a "
        "sensor_msgs/PointCloud2 per frame in livox_ros_driver2's point layout (x, y, z, intensity, tag, "
        "line = head, timestamp) plus offset_time and instance_id, the boxes as a visualization_msgs/"
        "MarkerArray with track ids, and the sensor poses on /tf_static; stamps are game time. Datasets "
        "that keep no sensor per point (KITTI, OpenPCDet) give one /simgen/points topic and no per-point "
        "time. Play it with `ros2 bag play FILE`, open it in Foxglove, or read it with rosbags or mcap.",
    )
    add_dataset_argument(parser)
    parser.add_argument("--format", choices=EXPORT_FORMATS, default="mcap", help="output format (default mcap)")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="FILE", help="bag file to write, e.g. clip.mcap")
    parser.add_argument("--clip", help="clip id (default: the first clip)")
    parser.add_argument("--frames", default=":", metavar="A:B", help="frames A to B-1 (Python slice; default all)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from tqdm import tqdm

    from simgen.datasets import open_dataset
    from simgen.datasets.ros2_bag import write_bag

    if args.output.is_dir():
        raise UserError(f"{args.output}: is a directory, expected a file name")
    dataset = open_dataset(args.dataset)
    clip = args.clip if args.clip is not None else dataset.clips[0]
    frames = frame_range(args.frames, dataset.num_frames(clip))
    per_sensor = dataset.format in ("parquet", "mcap")
    progress = tqdm(frames, unit="frame", desc=f"{clip} -> {args.output.name}", dynamic_ncols=True)
    summary = write_bag(args.output, (dataset.frame(clip, i) for i in progress), list(dataset.manifest.sensors), per_sensor)
    print(f"{args.output}: {summary.frames} frames of {clip}, {summary.messages} messages (ROS 2, MCAP)")
    return 0
