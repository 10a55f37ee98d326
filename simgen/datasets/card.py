"""The dataset card (README.md beside manifest.json), generated from the manifest alone."""

from __future__ import annotations

import json
from pathlib import PurePath

import pyarrow as pa

from simgen.datasets import kitti_camera as camera
from simgen.datasets import openpcdet_config, ros2_bag
from simgen.datasets.manifest import MANIFEST_NAME, Manifest
from simgen.datasets.samples import INTENSITY_SCALE, MAX_FRAMES_PER_CLIP, VAL_FRACTION
from simgen.datasets.schema import BOX_CONVENTION, PITCH_FRAME, TABLES
from simgen.labels.statistics import summary_rows
from simgen.vocab import BALL_INSTANCE_ID, OFFICIAL_CLASS, PLAYER_CLASS, SEMANTIC_NAMES


def _table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    return lines + ["| " + " | ".join(str(v) for v in row) + " |" for row in rows]


def _schema_rows(schema: pa.Schema) -> list[list]:
    def meta(field: pa.Field, key: bytes) -> str:
        return (field.metadata or {}).get(key, b"").decode()

    def kind(type_: pa.DataType) -> str:
        return f"{type_.value_type} (dictionary)" if pa.types.is_dictionary(type_) else str(type_)

    return [[f"`{f.name}`", f"`{kind(f.type)}`", meta(f, b"unit") or "-", meta(f, b"doc")] for f in schema]


def _parquet_layout() -> list[str]:
    lines = [
        "Apache Parquet, zstd, laid out like Waymo Open Dataset v2: one table per component, a file per clip",
        "(`<table>/<clip id>/part-0.parquet`) whose rows carry their keys `clip` and `frame` inside the file (so a",
        "file copied out of its folder still says what it holds), and `sensors/part-0.parquet` once per dataset.",
        "`points` row groups hold 10 whole frames (group g: frames 10 g .. 10 g + 9); `frames` and `boxes` row groups",
        "hold whole frames. Units and meanings are in each field's metadata (`unit`, `doc`), which only pyarrow shows,",
        "and, for duckdb, polars and pandas, as rows of the `units` table (`units/part-0.parquet`, once per dataset):",
        "`duckdb -c \"select * from 'units/*.parquet' where table_name = 'points'\"`.",
    ]
    for name, schema in TABLES.items():
        lines += ["", f"### `{name}`", "", *_table(["column", "type", "unit", "meaning"], _schema_rows(schema))]
    return lines


def _kitti_layout(tracking: bool, images: bool = False) -> list[str]:
    if tracking:
        files = [
            "- `training/velodyne/SSSS/NNNNNN.bin`: SSSS the clip index, NNNNNN the frame index in the clip",
            "- `training/label_02/SSSS.txt`: `frame track_id type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry`",
            "- `training/calib/SSSS.txt`: KITTI tracking calib (`P0:`-`P3:`, `R_rect`, `Tr_velo_cam`, `Tr_imu_velo`)",
            "- `training/placements/SSSS.txt`: `frame track_id` of each box with a discontinuity (Restarts, below); KITTI's",
            "  tracking tools ignore the folder",
        ]
    else:
        files = [
            f"- `training/velodyne/NNNNNN.bin`: NNNNNN = clip index x {MAX_FRAMES_PER_CLIP} + frame index",
            "- `training/label_2/NNNNNN.txt`: `type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry`",
            "- `training/calib/NNNNNN.txt`: KITTI object calib (`P0:`-`P3:`, `R0_rect:`, `Tr_velo_to_cam:`, `Tr_imu_to_velo:`)",
            "- `ImageSets/train.txt`, `val.txt`, `trainval.txt`: sample numbers, split by clip",
        ]
        if images:
            files.append("- `training/image_2/NNNNNN.png`: blank placeholders of the virtual camera's nominal size (1-bit PNG),"
                         " for tools that open every image (OpenPCDet's KITTI info generation)")
    min_height_m = camera.MIN_BOX_PX * (camera.CAMERA_DISTANCE_M + camera.MAX_X_M) / camera.FOCAL_PX
    return [
        *files,
        "",
        f"`.bin`: float32 x, y, z (metres, **pitch frame**, not the sensor's), intensity / {INTENSITY_SCALE:g} in [0, 1].",
        "The \"velodyne\" frame of these files is the pitch frame: KITTI tools that assume a sensor at the origin",
        "looking along +x (range crops, field-of-view filters) need the pitch's range instead.",
        "",
        "Labels are in a **virtual camera** (a stationary LiDAR over a pitch has none), stated exactly in `calib/`:",
        f"a pinhole at pitch (-{camera.CAMERA_DISTANCE_M:g}, 0, 0) m looking along +x with KITTI's camera axes,",
        f"`x_cam = -y`, `y_cam = -z`, `z_cam = x + {camera.CAMERA_DISTANCE_M:g}` (`Tr_velo_to_cam`; `R0_rect` = identity;",
        f"`Tr_imu_to_velo` = identity, there is no IMU), focal length {camera.FOCAL_PX:g} px, principal point",
        f"{camera.PRINCIPAL_PX} px, nominal image {camera.IMAGE_SIZE_PX[0]} x {camera.IMAGE_SIZE_PX[1]} px (image files only as placeholders).",
        "`location` is the box's bottom centre in that camera, `h w l` its height, width (across the heading) and",
        "length (along it), `ry = -yaw - pi/2`; `alpha = ry - atan2(x_cam, z_cam)`. The 2D box is the projection of",
        "the 8 corners with P2 (not clipped): a box",
        f"{min_height_m:.2f} m tall or more is at least {camera.MIN_BOX_PX:g} px tall anywhere up to x = {camera.MAX_X_M:g} m,",
        "so KITTI's evaluators (which drop boxes under 25-40 px) keep every humanoid.",
        "`truncated` is 0; `occluded` is 0, or 3 (unknown) for a humanoid with no point on it in that frame.",
    ]


def _openpcdet_layout() -> list[str]:
    return [
        "OpenPCDet's custom format (`pcdet/datasets/custom`), no conversion needed:",
        "",
        f"- `points/NNNNNN.npy`: float32 (N, 4) x, y, z (metres, pitch frame), intensity / {INTENSITY_SCALE:g} in [0, 1]",
        "- `labels/NNNNNN.txt`: `x y z dx dy dz heading name`, the box convention below (OpenPCDet's own)",
        "- `ImageSets/train.txt`, `val.txt`, `trainval.txt`: sample numbers, split by clip",
        "",
        f"NNNNNN = clip index x {MAX_FRAMES_PER_CLIP} + frame index. The `POINT_CLOUD_RANGE` must cover the pitch about",
        "its centre (the points are not centred on the sensor).",
        "",
        "### OpenPCDet",
        "",
        *openpcdet_config.card_lines(),
    ]


def _loading(manifest: Manifest) -> list[str]:
    lines = [
        "With simgen (every format; checks each file's sha256 against the manifest the first time it is read):",
        "",
        "```python",
        "import simgen.datasets",
        "data = simgen.datasets.open('.')",
        "frame = data.frame(data.clips[0], 0)      # points_m (P, 3), intensity, boxes (H, 7), class_name, ...",
        "history = data.sequence(data.clips[0], 2, length=3)   # frames 0, 1, 2",
        "```",
    ]
    if manifest.format == "parquet":
        lines += [
            "",
            "As is, with the usual tools:",
            "",
            "```python",
            "import pandas as pd; points = pd.read_parquet('points')            # clip and frame are columns",
            "import polars as pl; boxes = pl.read_parquet('boxes/**/*.parquet')",
            "import pyarrow.dataset as ds; frames = ds.dataset('frames').to_table()",
            "```",
            "",
            "```sh",
            "duckdb -c \"select clip, frame, count(*) from 'points/**/*.parquet' group by all order by all\"",
            "duckdb -c \"select column_name, unit, doc from 'units/*.parquet' where table_name = 'boxes'\"",
            "```",
            "",
            "(`duckdb` is the `duckdb-cli` package, on the PATH of simgen's `.venv`.)",
        ]
    return lines


def _by_name(value: object, key: str = "") -> object:
    """The scenario as the card shows it: a replay head's `file` (an absolute path once resolved) by its name
    only, so that the card never shows the author's folders."""
    if isinstance(value, dict):
        return {k: _by_name(v, k) for k, v in value.items()}
    if isinstance(value, list):
        return [_by_name(v) for v in value]
    if key == "file" and isinstance(value, str) and PurePath(value).is_absolute():
        return PurePath(value).name
    return value


def dataset_card(manifest: Manifest) -> str:
    scenario = manifest.scenario
    shown = _by_name(scenario)
    totals = manifest.to_dict()["totals"]
    splits = {s: sum(c.frames for c in manifest.clips if c.split == s) for s in ("train", "val")}
    frames = f"{totals['frames']} ({splits['train']} / {splits['val']})"
    layout = {
        "parquet": _parquet_layout,
        "kitti": lambda: _kitti_layout(False, bool(scenario.get("dataset", {}).get("kitti_images"))),
        "kitti_tracking": lambda: _kitti_layout(True),
        "openpcdet": _openpcdet_layout,
        "mcap": ros2_bag.card_lines,
    }[manifest.format]()
    sensor_keys = list(manifest.sensors[0]) if manifest.sensors else []
    lines = [
        f"# {scenario.get('name', 'simgen dataset')}: simulated Livox LiDAR over football ({manifest.format})",
        "",
        str(scenario.get("description") or "Simulated sparse, stationary Livox LiDAR watching a football match, labelled."),
        "",
        "Generated by simgen; this card is written from `manifest.json`, which lists the resolved scenario, the seed, the",
        "versions that made the data and every file's row count and sha256.",
        "",
        *_table(
            ["format", "schema", "clips", "frames (train / val)", "points", "boxes", "seed", "simgen"],
            [[manifest.format, manifest.schema_version, len(manifest.clips), frames, totals["points"], totals["boxes"],
              manifest.seed, manifest.simgen_version]],
        ),
        "",
        "## Frames, units, classes",
        "",
        f"- Coordinates: {PITCH_FRAME}. Times in seconds, angles in radians unless a name ends in `_deg`.",
        "- Time: game time (seconds since kick-off) in every format and tool: a frame's time is its sweep's start, its",
        "  boxes describe the middle of the sweep (its label time), a point's time is its shot's (Parquet",
        "  `points.time_offset_s` after the frame's start, MCAP `timestamp` / `offset_time`). KITTI and OpenPCDet files",
        "  keep no time: each clip's `start_s` in `manifest.json` gives frame k's, `start_s + k / frame_rate_hz`",
        "  (`simgen.datasets.open` fills `time_s` and `label_time_s`); their points keep no time of their own.",
        f"- Boxes: 7 numbers, {BOX_CONVENTION}.",
        f"- Classes: `{PLAYER_CLASS}` for players (both teams), `{OFFICIAL_CLASS}` for the referee and linesmen; the ball is not",
        f"  labelled (in Parquet its points have instance id {BALL_INSTANCE_ID} and semantic class `ball`).",
        "- Semantic classes of points: " + ", ".join(f"{i} `{name}`" for i, name in enumerate(SEMANTIC_NAMES)) + ".",
        f"- Split: by clip, the last {VAL_FRACTION:.0%} of the clips (at least one of two or more) is `val`.",
        "- Restarts: before a free kick, goal kick or throw-in the football engine places the players (and the ball)",
        "  where the restart wants them, in one 10 ms physics step. Nothing is interpolated across a placement: a shot",
        "  before it sees the humanoid where it was, a shot after it where it was put. Its track id stays (same person);",
        "  its box in the frames around the placement has `discontinuity` set (Parquet `boxes.discontinuity`, KITTI",
        "  tracking `training/placements/`, MCAP a `placed` marker in namespace `discontinuity`): the box may jump from the",
        "  previous frame's, the frame's points of it may lie at both places, and its velocity is taken within its segment.",
        "",
        "## Labels",
        "",
        f"Over every clip ({manifest.labels.get('frame_pairs') or 0:,.0f} pairs of consecutive frames of a track, none across "
        "a placement; simgen.labels.statistics): how much a box changes from one frame to the next, and its points.",
        "",
        *_table(["quantity", "median", "90th percentile", "99th percentile"], summary_rows(manifest.labels)),
        "",
        "## Layout",
        "",
        *layout,
        "",
        "## Sensors",
        "",
        "`pose`: x, y, z (metres), roll, pitch, yaw (degrees), pitch frame.",
        "",
        *(_table(sensor_keys, [[s[k] for k in sensor_keys] for s in manifest.sensors]) if sensor_keys else ["(none listed)"]),
        "",
        "## Loading",
        "",
        *_loading(manifest),
        "",
        "## Integrity",
        "",
        f"`{MANIFEST_NAME}` lists every file with its bytes and sha256; the same scenario and seed give byte-identical",
        "files. simgen's reader refuses a file whose checksum differs, and a Parquet file of another schema version.",
        "",
        "## Scenario (resolved)",
        "",
        *(["Replay files by name (`manifest.json` has the paths they were read from).", ""] if shown != scenario else []),
        "```json",
        json.dumps(shown, indent=2, sort_keys=True),
        "```",
        "",
        "## Versions",
        "",
        *_table(["package", "version"], [[k, v] for k, v in sorted(manifest.dependencies.items())]),
        "",
    ]
    return "\n".join(lines)
