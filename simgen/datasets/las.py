"""Frames as one LAS 1.4 point cloud (laspy), for CloudCompare, PDAL and QGIS.

Point format 6, x, y, z in the pitch frame (metres, scale SCALE_M), and per point:

- `gps_time`: the shot's game time (s since kick-off, the frame's `time_s` + the point's `time_offset_s`; the
  header says GPS week time, which game time is not);
- `classification`: the point's semantic class, `CLASS_CODES` (ASPRS's ground, user classes 64-68 for the
  rest, surroundings unclassified), named in a Classification Lookup VLR;
- `point_source_id`: the lidar unit that fired (its sensor and head, numbered as `simgen.datasets.units`);
- `intensity`: reflectivity 0-255 x 257 (LAS's 16-bit scale; // 257 gives it back);
- return 1 of 1; extra bytes `instance_id` (int32: track id, 1000 the ball, -1 nothing) and `line` (uint8: the
  laser of the head that fired).

laspy is imported only when a LAS file is written.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simgen import __version__
from simgen.atomic import atomic_path
from simgen.datasets.frame import Frame
from simgen.datasets.units import unit_numbers
from simgen.vocab import SEMANTIC_NAMES

if TYPE_CHECKING:
    from simgen.scan.sensor import Sensor

POINT_FORMAT = 6
SCALE_M = 1e-4  # metres: coordinates are kept to 0.1 mm
#: LAS classification per semantic class: ASPRS's where one fits, else user-definable (64-255).
CLASS_CODES = {"ground": 2, "line": 64, "player": 65, "official": 66, "ball": 67, "goal": 68, "surroundings": 1}
INTENSITY_FACTOR = 257  # 0-255 to LAS's 0-65535
#: The header's creation date, fixed so that the same frames give the same bytes.
CREATION_DATE = datetime.date(1970, 1, 1)


def classification(semantic: np.ndarray) -> np.ndarray:
    """(P,) LAS classes of (P,) semantic class indices (`simgen.vocab.SEMANTIC_NAMES`)."""
    return np.array([CLASS_CODES[name] for name in SEMANTIC_NAMES], np.uint8)[np.asarray(semantic)]


def _header(sensors: Sequence[Sensor]):
    import laspy
    from laspy.vlrs.known import ClassificationLookupVlr

    header = laspy.LasHeader(point_format=POINT_FORMAT, version="1.4")
    header.scales, header.offsets = np.full(3, SCALE_M), np.zeros(3)
    header.generating_software = f"simgen {__version__}"
    header.system_identifier = "simgen " + ", ".join(s.name for s in sensors)[:24]
    header.creation_date = CREATION_DATE
    header.add_extra_dims([
        laspy.ExtraBytesParams("instance_id", np.int32, "track id 1000 ball -1 none"),
        laspy.ExtraBytesParams("line", np.uint8, "laser of the head"),
    ])
    lookup = ClassificationLookupVlr()
    for name, code in CLASS_CODES.items():
        lookup[code] = name
    header.vlrs.append(lookup)
    return header


def _points(header, frame: Frame, sensors: Sequence[Sensor]):
    import laspy

    points = laspy.ScaleAwarePointRecord.zeros(len(frame.points_m), header=header)
    xyz = np.asarray(frame.points_m, np.float64)
    points.x, points.y, points.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    points.gps_time = frame.time_s + frame.time_offset_s.astype(np.float64)
    points.classification = classification(frame.semantic)
    points.point_source_id = unit_numbers(frame.sensor, frame.head, sensors).astype(np.uint16)
    points.intensity = np.asarray(frame.intensity, np.uint16) * INTENSITY_FACTOR
    one = np.ones(len(points), np.uint8)
    points.return_number, points.number_of_returns = one, one
    points.instance_id, points.line = frame.instance_id, frame.line
    return points


def write_las(path: Path, frames: Iterable[Frame], sensors: Sequence[Sensor]) -> tuple[int, int]:
    """Write `frames` (consumed one at a time; each with its time offsets, sensor, head, semantic class, line and
    instance id per point) to the LAS file `path`, atomically; (frames, points)."""
    import laspy

    count = points = 0
    header = _header(sorted(sensors, key=lambda s: s.sensor_id))
    with atomic_path(path) as tmp, laspy.open(tmp, mode="w", header=header) as writer:
        for frame in frames:
            writer.write_points(_points(header, frame, sensors))
            count, points = count + 1, points + len(frame.points_m)
    return count, points
