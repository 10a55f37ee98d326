"""OpenPCDet's custom format: `points/NNNNNN.npy`, `labels/NNNNNN.txt`, `ImageSets/{train,val}.txt`.

Points: .npy float32 (P, 5) x, y, z, intensity / 255, in the pitch frame as is (so OpenPCDet's
`POINT_CLOUD_RANGE` must cover the pitch, 105 x 68 m about the origin, not a range ahead of a
sensor), and the lidar unit (the head that fired, numbered across the sensors: `simgen.datasets.units`), which
OpenPCDet's custom dataset carries as a source feature its model does not use. Datasets written before the
unit column (P, 4) read too. Labels: one line
per humanoid, `x y z dx dy dz heading name`: centre, length (along the heading), width, height,
yaw counter-clockwise from +x (OpenPCDet's own box convention, which is ours), name `Pedestrian`
or `Official`. NNNNNN is the global sample number of simgen.datasets.samples.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simgen.datasets.frame import Frame, class_names
from simgen.datasets.limits import check_label_lines
from simgen.datasets.records import FileRecord, write_bytes, write_text
from simgen.datasets.samples import float32_text, from_xyzi, sample_name, to_xyzi
from simgen.datasets.units import unit_numbers, unit_sensor_head
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError
from simgen.vocab import CLASS_NAMES

if TYPE_CHECKING:
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor

COLUMNS = ("x", "y", "z", "intensity", "lidar_unit")  # of a points file; (P, 4) before the unit column


POINTS_DIR = "points"


def points_file(sample: str) -> str:
    """A sample's points file in POINTS_DIR."""
    return f"{sample}.npy"


def points_path(clip_index: int, index: int) -> str:
    return f"{POINTS_DIR}/{points_file(sample_name(clip_index, index))}"


def sample_labels_path(sample: str) -> str:
    return f"labels/{sample}.txt"


def labels_path(clip_index: int, index: int) -> str:
    return sample_labels_path(sample_name(clip_index, index))


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def label_lines(frame: LabelledFrame) -> list[str]:
    boxes = np.asarray(frame.labels.boxes, np.float32).reshape(-1, 7)
    names = class_names(frame.labels.team)
    return [" ".join([*(float32_text(v) for v in box), name]) for box, name in zip(boxes, names)]


class OpenPCDetClipStream:
    """One clip's OpenPCDet files written as its frames come: per frame its points and labels."""

    def __init__(self, root: Path, clip_index: int, sensors: Sequence[Sensor]):
        self.root, self.clip_index, self.sensors = Path(root), clip_index, sensors
        self.records: list[FileRecord] = []

    def add(self, frame: LabelledFrame) -> None:
        scan = frame.scan
        units = unit_numbers(scan.sensor, scan.head, self.sensors).astype(np.float32)[:, None]
        points = np.ascontiguousarray(np.concatenate([to_xyzi(scan.points_m, scan.intensity), units], axis=1))
        self.records.append(write_bytes(self.root, points_path(self.clip_index, frame.index), npy_bytes(points),
                                        len(points)))
        self.records.append(write_text(self.root, labels_path(self.clip_index, frame.index), label_lines(frame)))

    def close(self) -> list[FileRecord]:
        return self.records

    def abort(self) -> None:
        """Nothing to undo: every file is whole under its final name or absent."""


def parse_labels(text: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(H, 7) float32 boxes and (H,) class names."""
    rows = [line.split() for line in text.splitlines() if line.strip()]
    for number, row in enumerate(rows, 1):
        if len(row) != 8 or row[7] not in CLASS_NAMES:
            raise UserError(f"{path}: line {number} is not `x y z dx dy dz heading name` with a simgen class")
    try:
        boxes = np.array([row[:7] for row in rows], np.float32).reshape(-1, 7)
    except ValueError:
        raise UserError(f"{path}: a label has a field that is not a number") from None
    return boxes, np.array([row[7] for row in rows], np.str_)


def read_points(data: bytes, path: Path, rows: int) -> np.ndarray:
    """(rows, 5) float32 (COLUMNS), or (rows, 4) from a dataset written before the unit column."""
    try:
        points = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise UserError(f"{path}: not a readable .npy file ({error})") from None
    if points.dtype != np.float32 or points.shape not in ((rows, len(COLUMNS)), (rows, 4)):
        raise UserError(f"{path}: {points.dtype} {points.shape}, expected float32 ({rows}, {len(COLUMNS)})")
    return points


class OpenPCDetReader:
    """Frames of an `openpcdet` dataset."""

    def __init__(self, files: DatasetFiles, clip_indices: dict[str, int], sensors: Sequence[Sensor]):
        self.files = files
        self.clip_indices = clip_indices
        self.sensors = sensors

    def frame(self, clip: str, index: int) -> Frame:
        clip_index = self.clip_indices[clip]
        points = points_path(clip_index, index)
        labels = labels_path(clip_index, index)
        array = read_points(self.files.read(points), self.files.root / points, self.files.rows(points))
        xyz, intensity = from_xyzi(array[:, :4])
        sensor = head = None
        if array.shape[1] == len(COLUMNS):
            try:
                sensor, head = unit_sensor_head(array[:, 4], self.sensors)
            except ValueError as error:
                raise UserError(f"{self.files.root / points}: {error}") from None
        text = self.files.read(labels).decode(errors="replace")
        check_label_lines(self.files.root / labels, text, 1)
        boxes, names = parse_labels(text, self.files.root / labels)
        return Frame(clip=clip, index=index, points_m=xyz, intensity=intensity, boxes=boxes, class_name=names,
                     sensor=sensor, head=head)
