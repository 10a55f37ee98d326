"""Labelled datasets on disk: Parquet (the default), KITTI, KITTI tracking, OpenPCDet's custom format and
ROS 2 bags in MCAP (`ros2_bag.py`).

Writing: `write_clip` per clip (clips may be written by different processes), then
`finish_dataset` once (ImageSets, manifest.json, README.md). Reading: `simgen.datasets.open(path)`,
the one way `train/` reads data, whatever the format.
"""

from simgen.datasets.frame import Frame
from simgen.datasets.manifest import FORMATS, Manifest
from simgen.datasets.reader import Dataset, open_dataset
from simgen.datasets.records import ClipRecord, FileRecord
from simgen.datasets.write import finish_dataset, write_clip

open = open_dataset  # noqa: A001 - simgen.datasets.open(path), as the issue names it

__all__ = [
    "FORMATS",
    "ClipRecord",
    "Dataset",
    "FileRecord",
    "Frame",
    "Manifest",
    "finish_dataset",
    "open",
    "open_dataset",
    "write_clip",
]
