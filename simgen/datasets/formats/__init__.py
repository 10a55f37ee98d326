"""Dataset formats as plug-ins: one module here per format (its writer, reader and `DatasetFormat`, base.py, as
`FORMAT`), and this registry of their names, modules and limits.

The rest of simgen asks `dataset_format(name)` what a format writes, reads and carries; it never
compares format names. A new format is a new module here and its line in `PLUGINS`. A format's
module is imported the first time it is asked for, so that naming the formats (the CLI's choices)
imports no writer library, and its limits are read here (`format_limits`), so that validating a
scenario imports no plug-in either.
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

from simgen.errors import UserError

if TYPE_CHECKING:
    from collections.abc import Callable

    from simgen.datasets.formats.base import DatasetFormat

#: Frames a clip may have where files are numbered by clip and frame (`simgen.datasets.samples.sample_number`).
MAX_FRAMES_PER_CLIP = 10_000


@dataclass(frozen=True)
class Limits:
    """What a scenario may ask of a format."""

    max_frames_per_clip: int | None = None  # None: no limit
    placeholder_images: bool = False  # takes `dataset.kitti_images` (blank images for tools that open them)


@dataclass(frozen=True)
class Plugin:
    module: str
    limits: Limits


#: Format name -> its module and limits; the first is the default.
PLUGINS = {
    "parquet": Plugin("simgen.datasets.formats.parquet", Limits()),
    "kitti": Plugin("simgen.datasets.formats.kitti", Limits(MAX_FRAMES_PER_CLIP, placeholder_images=True)),
    "kitti_tracking": Plugin("simgen.datasets.formats.kitti_tracking", Limits(MAX_FRAMES_PER_CLIP)),
    "openpcdet": Plugin("simgen.datasets.formats.openpcdet", Limits(MAX_FRAMES_PER_CLIP)),
    # the limit every format but parquet had; the reader decodes a clip whole
    "mcap": Plugin("simgen.datasets.formats.mcap", Limits(MAX_FRAMES_PER_CLIP)),
}
FORMATS = tuple(PLUGINS)


def _known(name: str) -> Plugin:
    if name not in PLUGINS:
        raise UserError(f"unknown dataset format {name!r} (choose from {', '.join(FORMATS)})")
    return PLUGINS[name]


@functools.cache
def _load(name: str) -> DatasetFormat:
    return importlib.import_module(PLUGINS[name].module).FORMAT


def dataset_format(name: str) -> DatasetFormat:
    """The format called `name`; an unknown name is a one-line `UserError`."""
    _known(name)
    return _load(name)


def format_limits(name: str) -> Limits:
    """The limits of the format called `name`, without importing it; an unknown name is a one-line `UserError`."""
    return _known(name).limits


def formats_where(test: Callable[[DatasetFormat], bool]) -> list[str]:
    """Names of the formats for which `test(format)` is true, in registry order (for messages)."""
    return [name for name in FORMATS if test(dataset_format(name))]


def formats_allowing(test: Callable[[Limits], bool]) -> list[str]:
    """Names of the formats whose limits pass `test`, in registry order (for messages), importing none."""
    return [name for name in FORMATS if test(PLUGINS[name].limits)]
