"""Labelled datasets on disk: Parquet (the default), KITTI, KITTI tracking, OpenPCDet's custom format and
ROS 2 bags in MCAP, each a plug-in of `simgen.datasets.formats`.

Writing: `write_clip` per clip (clips may be written by different processes), then
`finish_dataset` once (the format's dataset files, manifest.json, README.md). Reading:
`simgen.datasets.open(path)`, the one way `train/` reads data, whatever the format.

The names below are imported when first used, so that `simgen.datasets.formats` (the format names,
for the CLI and the scenario's schema) imports no writer or reader.
"""

from __future__ import annotations

import importlib

_HOMES = {
    "FORMATS": "simgen.datasets.formats",
    "ClipRecord": "simgen.datasets.records",
    "Dataset": "simgen.datasets.reader",
    "FileRecord": "simgen.datasets.records",
    "Frame": "simgen.datasets.frame",
    "Manifest": "simgen.datasets.manifest",
    "finish_dataset": "simgen.datasets.write",
    "open": "simgen.datasets.reader",  # simgen.datasets.open(path) is open_dataset
    "open_dataset": "simgen.datasets.reader",
    "write_clip": "simgen.datasets.write",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), "open_dataset" if name == "open" else name)
    globals()[name] = value
    return value
