"""Dataset formats as plug-ins: one module here per format, each holding a `DatasetFormat` (base.py) as `FORMAT`.

The rest of simgen asks `dataset_format(name)` what a format writes, reads and carries; it never
compares format names. A new format is a new module here and its line in `PLUGINS`. A format's
module is imported the first time it is asked for, so that naming the formats (the CLI's choices,
the scenario's schema) imports no writer library.
"""

from __future__ import annotations

import functools
import importlib
from typing import TYPE_CHECKING

from simgen.errors import UserError

if TYPE_CHECKING:
    from simgen.datasets.formats.base import DatasetFormat

#: Format name -> its module; the first is the default.
PLUGINS = {
    "parquet": "simgen.datasets.formats.parquet",
    "kitti": "simgen.datasets.formats.kitti",
    "kitti_tracking": "simgen.datasets.formats.kitti_tracking",
    "openpcdet": "simgen.datasets.formats.openpcdet",
    "mcap": "simgen.datasets.formats.mcap",
}
FORMATS = tuple(PLUGINS)


@functools.cache
def _load(name: str) -> DatasetFormat:
    return importlib.import_module(PLUGINS[name]).FORMAT


def dataset_format(name: str) -> DatasetFormat:
    """The format called `name`; an unknown name is a one-line `UserError`."""
    if name not in PLUGINS:
        raise UserError(f"unknown dataset format {name!r} (choose from {', '.join(FORMATS)})")
    return _load(name)


def formats_where(test) -> list[str]:
    """Names of the formats for which `test(format)` is true, in registry order (for messages)."""
    return [name for name in FORMATS if test(dataset_format(name))]
