"""The one interface every dataset format implements: `DatasetFormat`, and what it carries (`Carries`).

A format writes a clip through its `stream` and reads it back through its `reader`; it names the
files of a clip (`clip_files`) and those written once per dataset (`finish`, `dataset_files`); it
writes its part of the dataset card (`card_layout`, `card_loading`) and of `simgen verify`
(`file_problem`, `locator`, `clip_problems`, `frame_counts`). Subclasses set the class attributes
and override the methods that differ from the defaults here.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar, Protocol

from simgen.datasets.formats import Limits, format_limits

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from simgen.datasets.frame import Frame
    from simgen.datasets.manifest import ClipEntry, Manifest
    from simgen.datasets.records import ClipRecord, FileRecord
    from simgen.datasets.verify import DatasetFiles, Problem
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor

#: Where box `i` of frame `k` of a clip is stored: (file, row), row as the format counts it.
Locate = Callable[[int, int], tuple[str, int]]


class ClipStream(Protocol):
    """One clip's files written as its frames come; `close` returns their records, `abort` leaves no
    file under a final name."""

    def add(self, frame: LabelledFrame) -> None: ...

    def close(self) -> list[FileRecord]: ...

    def abort(self) -> None: ...


class FrameReader(Protocol):
    def frame(self, clip: str, index: int) -> Frame: ...


@dataclass(frozen=True)
class Carries:
    """What a format keeps besides each frame's points (x, y, z, intensity) and boxes with their class."""

    track_ids: bool  # each box's track id (and its discontinuity flag)
    point_fields: bool  # each point's sensor, shot time, laser line and instance id (Parquet also its head and sweep)
    point_counts: bool  # each box's stored number of points
    units: bool = False  # each point's lidar unit: its sensor and head (`simgen.datasets.units`)


class DatasetFormat(ABC):
    """A dataset format; its module in `simgen.datasets.formats` holds one instance, `FORMAT`, and the registry
    its limits (`limits`)."""

    name: ClassVar[str]  # as manifest.json and the scenario's dataset.format name it
    carries: ClassVar[Carries]
    #: A file per frame: a clip rendered in frame ranges writes its final files range by range.
    frame_files: ClassVar[bool] = False
    #: `simgen pack` can carry it (its points are Parquet tables).
    packable: ClassVar[bool] = False

    @property
    def limits(self) -> Limits:
        """What a scenario may ask of this format (frames per clip, placeholder images)."""
        return format_limits(self.name)

    @abstractmethod
    def stream(self, root: Path, clip: str, clip_index: int, sensors: Sequence[Sensor]) -> ClipStream:
        """The writer of one clip under `root`."""

    @abstractmethod
    def reader(self, files: DatasetFiles, manifest: Manifest) -> FrameReader:
        """Frames of a written dataset, read only through `files`."""

    @abstractmethod
    def clip_files(self, entry: ClipEntry) -> set[str]:
        """Relative paths of every file a clip's frames are read from."""

    def dataset_files(self, manifest: Manifest) -> set[str]:
        """Relative paths of the files `finish` writes once per dataset."""
        return set()

    def finish(
        self, root: Path, clips: Sequence[ClipRecord], sensors: Sequence[Sensor], scenario: Mapping
    ) -> list[FileRecord]:
        """Write what needs every clip (or no clip), before the card and the manifest; their records."""
        return []

    def listed_rows_problem(self, entry: ClipEntry, listed: Mapping[str, FileRecord], sensors: int) -> str | None:
        """Why the rows the manifest lists for a clip's files cannot be its `entry.frames` frames, if they cannot."""
        return None

    @abstractmethod
    def card_layout(self, manifest: Manifest) -> list[str]:
        """The dataset card's Layout section: the files and what they hold."""

    def card_loading(self) -> list[str]:
        """Lines the dataset card's Loading section adds after simgen's reader: other tools that read it."""
        return []

    def summary_lines(self, output: str) -> list[str]:
        """Lines `simgen generate` adds to its summary: how to look at the dataset in `output` with other tools."""
        return []

    def file_problem(self, path: Path, relative: str) -> str | None:
        """`simgen verify`: what is wrong inside a listed file whose sha256 matched, if anything."""
        return None

    @abstractmethod
    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        """Where box i of frame k is stored; `first_row[k]` (the clip's boxes before frame k) is filled while
        reading."""

    def clip_problems(self, files: DatasetFiles, entry: ClipEntry, sizes: Sequence[tuple[int, int]]) -> list[Problem]:
        """`simgen verify`: the format's own bookkeeping of a clip against its frames' (points, boxes)."""
        return []

    def frame_counts(self, files: DatasetFiles, clips: Sequence[str]) -> dict[str, NDArray[np.int64]] | None:
        """Per frame of `clips`, in order: num_points, shots, dropped, missed; None: the format keeps no shot counts."""
        return None
