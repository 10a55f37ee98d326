"""The Parquet tables of a dataset: their Arrow schemas, units and frames in the field metadata.

Four tables, as Waymo Open Dataset v2 lays out its components: `frames` (one row per frame),
`points` (one row per point, row groups of 10 whole frames) and `boxes` (one row per labelled humanoid
per frame) in a file per clip (`<table>/<clip id>/part-0.parquet`), each row carrying its keys
(`clip`, `frame`) inside the file, as Waymo's `key.*` columns do, so a file copied out of its
folder still says what it holds; and `sensors` (one row per sensor), once per dataset
(`sensors/part-0.parquet`). Every field carries `doc` and `unit` metadata, which only pyarrow
shows: the `units` table (`units/part-0.parquet`, once per dataset) holds the same as rows, for
duckdb, polars and pandas. Every file carries `simgen.dataset` schema metadata (JSON: schema
version, table name, pitch frame), which the reader checks.
"""

from __future__ import annotations

import json

import pyarrow as pa

from simgen.vocab import BALL_INSTANCE_ID, KEYPOINT_NAMES, NUM_KEYPOINTS, SEMANTIC_NAMES

SCHEMA_VERSION = 7  # 2: `clip` and `frame` columns in every per-clip table, `sensors` once per dataset, points.sweep;
#                    3: `points` row groups of 10 frames instead of one each; 4: boxes.discontinuity;
#                    5: each clip's `start_s` in the manifest (the frames' game time in every format), a `units` table;
#                    6: points.line; 7: label statistics in the manifest
METADATA_KEY = b"simgen.dataset"
PITCH_FRAME = "pitch: origin at the centre spot, x towards the right team's goal, y left, z up; metres"
BOX_CONVENTION = (
    "x, y, z box centre; length along the heading, width across it, height along z; "
    "yaw turns the heading counter-clockwise from +x, radians in (-pi, pi]"
)


def _field(name: str, type_: pa.DataType, doc: str, unit: str = "") -> pa.Field:
    return pa.field(name, type_, nullable=False, metadata={"doc": doc, "unit": unit})


def _metres(name: str, doc: str) -> pa.Field:
    return _field(name, pa.float32(), f"{doc}, pitch frame", "m")


CLIP_FIELD = _field("clip", pa.dictionary(pa.int32(), pa.string()), "clip id (the file's folder name)")
FRAME_FIELD = _field("frame", pa.int32(), "frame index in the clip, from 0")

FRAMES = pa.schema(
    [
        CLIP_FIELD,
        FRAME_FIELD,
        _field("time_s", pa.float64(), "game time of the start of the frame's sweep(s)", "s"),
        _field("label_time_s", pa.float64(), "game time the boxes describe (the middle of the sweep)", "s"),
        _field("num_points", pa.int32(), "points of the frame (rows of `points`)"),
        _field("num_boxes", pa.int32(), "labelled humanoids of the frame (rows of `boxes`)"),
        _field("shots", pa.int64(), "shots fired in the frame, all sensors"),
        _field("dropped", pa.int64(), "returns lost to random dropout"),
        _field("missed", pa.int64(), "shots with no return in range (sky, too near, too far)"),
    ]
)

POINTS = pa.schema(
    [
        CLIP_FIELD,
        FRAME_FIELD,
        _metres("x", "point x"),
        _metres("y", "point y"),
        _metres("z", "point z"),
        _field("intensity", pa.uint8(), "Livox calibrated reflectivity 0-255 (0-150 diffuse)"),
        _field("time_offset_s", pa.float32(), "shot time since the frame's start", "s"),
        _field("sensor", pa.uint8(), "sensor index in the scenario (sensors.sensor_id)"),
        _field("head", pa.uint8(), "head index in its sensor"),
        _field(
            "sweep",
            pa.uint8(),
            "sweep of the frame the shot belongs to, 0 .. sensors.sweeps_per_frame - 1 (time order)",
        ),
        _field(
            "line",
            pa.uint8(),
            "laser of the head that fired the shot (Livox's `line`): shot k of a head fires laser (k - 1) mod its "
            "lasers",
        ),
        _field(
            "instance_id",
            pa.int32(),
            f"track id of the humanoid hit (boxes.track_id), {BALL_INSTANCE_ID} for the ball, -1 for anything else",
        ),
        _field(
            "semantic",
            pa.uint8(),
            "semantic class: " + ", ".join(f"{i} {name}" for i, name in enumerate(SEMANTIC_NAMES)),
        ),
    ]
)

BOX_FIELDS = ("x", "y", "z", "length", "width", "height", "yaw")

BOXES = pa.schema(
    [
        CLIP_FIELD,
        FRAME_FIELD,
        _field("track_id", pa.int32(), "humanoid id, stable over the clip"),
        _field("team", pa.dictionary(pa.int8(), pa.string()), "left, right or official"),
        _field("role", pa.dictionary(pa.int8(), pa.string()), "GK, CB, ... or referee, linesman"),
        _metres("x", "box centre x"),
        _metres("y", "box centre y"),
        _metres("z", "box centre z"),
        _field("length", pa.float32(), "box size along the heading", "m"),
        _field("width", pa.float32(), "box size across the heading", "m"),
        _field("height", pa.float32(), "box size along z", "m"),
        _field("yaw", pa.float32(), "heading, counter-clockwise from +x, in (-pi, pi]", "rad"),
        _field(
            "velocity_mps", pa.list_(pa.float32(), 3), "velocity (x, y, z) of the `middle` keypoint, pitch frame", "m/s"
        ),
        _field(
            "keypoints_m",
            pa.list_(pa.float32(), NUM_KEYPOINTS * 3),
            "12 body parts x (x, y, z), pitch frame, order: " + ", ".join(KEYPOINT_NAMES),
            "m",
        ),
        _field("num_points", pa.int32(), "points of the frame hit on this humanoid"),
        _field(
            "discontinuity",
            pa.bool_(),
            "the engine placed this humanoid for a restart between the previous frame's label time and the end of "
            "this frame's sweep: the box may jump from the previous frame's (same track id), "
            "its points may lie at both places",
        ),
    ]
)

#: The `sensors` table's columns of `Sensor.pose` (the rest are named as `Sensor.record`'s keys).
SENSOR_POSE_COLUMNS = ("x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg")
SENSORS = pa.schema(
    [
        _field("sensor_id", pa.int32(), "index in the scenario's sensor list (points.sensor)"),
        _field("name", pa.string(), "sensor name in the scenario"),
        _field("preset", pa.string(), "scan_patterns sensor preset"),
        _field("x", pa.float64(), "sensor position x, pitch frame", "m"),
        _field("y", pa.float64(), "sensor position y, pitch frame", "m"),
        _field("z", pa.float64(), "sensor position z, pitch frame", "m"),
        _field("roll_deg", pa.float64(), "roll about x (applied yaw, pitch, roll)", "deg"),
        _field("pitch_deg", pa.float64(), "pitch about y, positive looking up", "deg"),
        _field("yaw_deg", pa.float64(), "yaw about z, 0 looking along +x, 90 along +y", "deg"),
        _field("heads", pa.int32(), "laser heads of the sensor"),
        _field("shots_per_s", pa.float64(), "shots per second, all heads, after the density factor", "1/s"),
        _field("frame_rate_hz", pa.float64(), "frames per second", "Hz"),
        _field("sweeps_per_frame", pa.int32(), "sweeps merged into one frame"),
        _field("density", pa.float64(), "shots per second as a multiple of the real sensor's"),
    ]
)

UNITS = pa.schema(
    [
        _field("table_name", pa.string(), "a table of the dataset (its folder)"),
        _field("column_name", pa.string(), "a column of that table"),
        _field("unit", pa.string(), "its unit (SI symbols; empty: a count, an index or a name)"),
        _field("doc", pa.string(), "what it holds"),
    ]
)

TABLES: dict[str, pa.Schema] = {"frames": FRAMES, "points": POINTS, "boxes": BOXES, "sensors": SENSORS, "units": UNITS}
CLIP_TABLES = ("frames", "points", "boxes")  # a file per clip; `sensors` and `units` are one file per dataset
DATA_TABLES = (*CLIP_TABLES, "sensors")  # the tables whose columns `units` describes


def units_rows() -> dict[str, list[str]]:
    """The `units` table's columns: each data table's field metadata as rows, for readers that drop
    field metadata (duckdb, polars, pandas)."""
    fields = [(name, field) for name in DATA_TABLES for field in TABLES[name]]
    return {
        "table_name": [name for name, _ in fields],
        "column_name": [field.name for _, field in fields],
        "unit": [field.metadata[b"unit"].decode() for _, field in fields],
        "doc": [field.metadata[b"doc"].decode() for _, field in fields],
    }


def with_table_metadata(schema: pa.Schema, table: str) -> pa.Schema:
    """`schema` with the `simgen.dataset` metadata the reader checks (no time stamps: bytes stay reproducible)."""
    metadata = {"schema_version": SCHEMA_VERSION, "table": table, "pitch_frame": PITCH_FRAME, "boxes": BOX_CONVENTION}
    return schema.with_metadata({METADATA_KEY: json.dumps(metadata, sort_keys=True)})
