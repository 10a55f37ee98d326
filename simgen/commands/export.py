"""`simgen export`: a clip of any simgen dataset as a ROS 2 bag in MCAP, or of a Parquet dataset as a LAS file."""

from __future__ import annotations

from pathlib import Path

from simgen.commands.arguments import add_command, add_dataset_argument, frame_range
from simgen.errors import UserError
from simgen.output_path import check_output

EXPORT_FORMATS = ("mcap", "las")
ROS2_LAYOUTS = ("simgen", "livox", "livox-custom", "livox-v1", "livox-v1-custom")


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "export",
        "a clip of a dataset as a ROS 2 bag (MCAP) or a LAS file",
        "Write the frames A:B of a clip of any simgen dataset as one ROS 2 bag in MCAP: per sensor a "
        "sensor_msgs/PointCloud2 per frame, the boxes as a visualization_msgs/MarkerArray with track ids at the "
        "label time, and the sensor poses on /tf_static (transient local, as tf2 publishes them); stamps are "
        "game time, as in every simgen output, and each channel carries rosbag2's offered QoS profiles. Points "
        "(--ros2-layout): `simgen` (default) in the pitch frame, livox_ros_driver2's point (x, y, z, intensity, "
        "tag, line = head, timestamp) plus offset_time and instance_id; `livox` exactly the driver's 26-byte "
        "point in each sensor's frame; and as Livox's drivers publish each lidar unit (a Mid-100's three units "
        "apart, lidar_id numbering the units of all sensors), in the sensor's frame, stamped at the unit's first "
        "point: `livox-custom` livox_ros_driver2's CustomMsg, `livox-v1` livox_ros_driver's 18-byte PointCloud2, "
        "`livox-v1-custom` its CustomMsg. --topic and --frame-id rename them (e.g. --topic livox/lidar "
        "--frame-id livox_frame, as the drivers' defaults). Datasets that keep no sensor per point (KITTI, "
        "OpenPCDet) give one /simgen/points topic of x, y, z, intensity, and the command says what they cannot "
        "carry. Play it with `ros2 bag play DIR`, open the .mcap in Foxglove, or read it with rosbags or mcap.",
    )
    add_dataset_argument(parser)
    parser.add_argument("--format", choices=EXPORT_FORMATS, default="mcap",
                        help="mcap (default): a ROS 2 bag; las: the frames' points as one LAS 1.4 file (laspy), GPS "
                        "time the shot's game time, classification the semantic class, point source id the lidar "
                        "unit (a Parquet dataset's)")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR",
        help="bag directory to create, as `ros2 bag record -o DIR` does: DIR/<name>.mcap and rosbag2's metadata.yaml "
        "(--format las: the .las file)",
    )
    parser.add_argument("--clip", help="clip id (default: the first clip)")
    parser.add_argument("--frames", default=":", metavar="A:B", help="frames A to B-1 (Python slice; default all)")
    parser.add_argument(
        "--ros2-layout",
        choices=ROS2_LAYOUTS,
        default="simgen",
        help="points: simgen (PointCloud2, pitch frame, 34 bytes, default), livox (livox_ros_driver2's "
        "26-byte PointCloud2, sensor frame), livox-custom (livox_ros_driver2's CustomMsg per lidar unit), livox-v1 "
        "(livox_ros_driver's 18-byte PointCloud2 per unit), livox-v1-custom (its CustomMsg per unit)",
    )
    parser.add_argument("--topic", metavar="TEMPLATE", help="points topic of a sensor or unit, from {sensor}, "
                        "{unit} (head) and {lidar_id} (default /simgen/{sensor}/points, per unit "
                        "/simgen/{sensor}/lidar_{unit})")
    parser.add_argument("--frame-id", metavar="TEMPLATE", help="frame of a livox layout's points (and its "
                        "/tf_static child), from {sensor}, {unit} and {lidar_id} (default {sensor})")
    parser.set_defaults(func=run)


def run(args) -> int:
    from tqdm import tqdm

    from simgen.datasets import open_dataset
    from simgen.datasets.formats import formats_where, mcap

    check_output(args.output, "file" if args.format == "las" else "folder", reads=[args.dataset], new=True)
    dataset = open_dataset(args.dataset)
    clip = args.clip if args.clip is not None else dataset.clips[0]
    frames = frame_range(args.frames, dataset.num_frames(clip))
    if args.format == "las":
        return _las(args, dataset, clip, frames)
    layout = mcap.LAYOUTS[args.ros2_layout]
    if not dataset.plugin.carries.point_fields:
        if layout.sensor_frame:
            per_point = formats_where(lambda f: f.carries.point_fields)
            raise UserError(f"--ros2-layout {layout.name}: a {dataset.format} dataset keeps no sensor, head or time "
                            f"per point (export a {' or '.join(per_point)} dataset)")
        layout = mcap.XYZI_LAYOUT
        ids = "" if dataset.plugin.carries.track_ids else "; no track ids: marker ids number each frame's boxes"
        print(f"{args.output}: {dataset.format} keeps no sensor, head, time or instance per point: x, y, z, intensity "
              f"on one topic, {mcap.ALL_POINTS_TOPIC}{ids}")
    sensors, naming = list(dataset.manifest.sensors), mcap.Naming(args.topic, args.frame_id)
    mcap.check_naming(naming, layout, sensors)
    first = dataset.frame(clip, frames.start)  # a clip that does not read is one line, before the progress bar
    mcap.check_heads(layout, sensors, first)
    progress = tqdm(frames, unit="frame", desc=f"{clip} -> {args.output.name}", dynamic_ncols=True)
    read = (first if i == frames.start else dataset.frame(clip, i) for i in progress)
    summary = mcap.write_bag(args.output, read, sensors, layout, naming)
    print(
        f"{args.output}: {summary.frames} frames of {clip}, {summary.messages} messages (ROS 2, MCAP, {layout.name} "
        f"points), in {mcap.bag_name(args.output)}.mcap and metadata.yaml"
    )
    return 0


def _las(args, dataset, clip: str, frames: range) -> int:
    from tqdm import tqdm

    from simgen.datasets.formats import formats_where
    from simgen.datasets.las import write_las

    if args.ros2_layout != "simgen" or args.topic is not None or args.frame_id is not None:
        raise UserError("--ros2-layout, --topic and --frame-id are for --format mcap")
    carries = dataset.plugin.carries
    if not (carries.point_fields and carries.units):
        per_point = formats_where(lambda f: f.carries.point_fields and f.carries.units)
        raise UserError(f"--format las: a {dataset.format} dataset keeps no shot time, semantic class or head per "
                        f"point (export a {' or '.join(per_point)} dataset)")
    progress = tqdm(frames, unit="frame", desc=f"{clip} -> {args.output.name}", dynamic_ncols=True)
    count, points = write_las(args.output, (dataset.frame(clip, i) for i in progress), dataset.manifest.sensors)
    print(f"{args.output}: {count} frames of {clip}, {points:,} points (LAS 1.4, point format 6)")
    return 0
