"""Writing a dataset: `write_clip` (or a streaming `ClipWriter`) once per clip, in any process and
order, then `finish_dataset` once. Frames go to disk as they come: memory does not grow with a clip.

Each format is a plug-in (`simgen.datasets.formats`): its stream writes a clip, its `finish` what
needs every clip. Clips never share a file (Parquet partitions by clip id, the KITTI-style formats
number samples by clip index), so clips can be written in parallel; `finish_dataset` then writes
the format's dataset files (ImageSets, Parquet's sensors and units tables), the dataset card
README.md and, last, manifest.json.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from simgen import __version__
from simgen.datasets.card import dataset_card
from simgen.datasets.formats import dataset_format
from simgen.datasets.manifest import MANIFEST_NAME, ClipEntry, Manifest, dependency_versions, manifest_bytes
from simgen.datasets.records import ClipRecord, write_bytes
from simgen.datasets.samples import val_clips
from simgen.datasets.schema import SCHEMA_VERSION
from simgen.errors import UserError
from simgen.labels.statistics import LabelStatistics
from simgen.vocab import TEAM_NAMES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor import Sensor

#: Clip ids become directory and file names: a leading letter, no '=' (not read as a hive partition).
CLIP_ID = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]*$")
CARD_NAME = "README.md"


def check_frame(clip: str, expected_index: int, frame: LabelledFrame) -> None:
    """One-line `UserError` unless `frame` is frame `expected_index` of `clip`, with known teams."""
    if frame.clip != clip or frame.index != expected_index:
        raise UserError(
            f"clip {clip}: frame {expected_index} is frame {frame.index} of clip {frame.clip}, "
            "expected the clip's frames in order"
            + (" from 0" if expected_index == 0 else "")
        )
    foreign = set(map(str, frame.labels.team)) - set(TEAM_NAMES)
    if foreign:
        raise UserError(
            f"clip {clip}, frame {expected_index}: unknown team {sorted(foreign)[0]!r} "
            f"(expected {', '.join(TEAM_NAMES)})"
        )


class ClipWriter:
    """Streams the frames of one clip (or of a range of its frames) to the format's files as they
    come, so memory does not grow with the clip's length; `close` returns the `ClipRecord`.

    Use as a context manager: an exception inside removes the files still under temporary names.
    Frames must come in order from `first_frame`."""

    def __init__(
        self, root: Path, format: str, clip: str, clip_index: int, sensors: Sequence[Sensor], first_frame: int = 0
    ):
        plugin = dataset_format(format)
        if not CLIP_ID.match(clip):
            raise UserError(f"clip id {clip!r}: use a letter, then letters, digits, '_', '.' or '-'")
        if clip_index < 0:
            raise UserError(f"clip {clip}: clip index {clip_index} is negative")
        self.format, self.clip, self.clip_index = format, clip, clip_index
        self.next_index, self.frames, self.points, self.boxes = first_frame, 0, 0, 0
        self.start_s = 0.0  # the first frame's time_s, once it comes
        self.labels = LabelStatistics.empty()
        self._stream = plugin.stream(Path(root), clip, clip_index, sensors)

    def add(self, frame: LabelledFrame) -> None:
        check_frame(self.clip, self.next_index, frame)
        self._stream.add(frame)
        if not self.frames:
            self.start_s = frame.time_s
        self.next_index += 1
        self.frames += 1
        self.points += len(frame.scan.points_m)
        self.boxes += len(frame.labels.boxes)
        labels = frame.labels
        self.labels.add(labels.track_id, labels.boxes, labels.discontinuity, labels.num_points)

    def after(self, track_id: NDArray, boxes: NDArray) -> None:
        """Count the first frame's box changes from the frame before it (boxes (H, 7) of a shard's previous frame,
        written by another shard), as the whole clip does; before the first `add`."""
        self.labels.add(track_id, boxes, None, None)

    def close(self) -> ClipRecord:
        if not self.frames:
            raise UserError(f"clip index {self.clip_index}: no frames to write")
        files = self._stream.close()
        return ClipRecord(
            format=self.format,
            clip=self.clip,
            clip_index=self.clip_index,
            frames=self.frames,
            points=self.points,
            boxes=self.boxes,
            start_s=self.start_s,
            files=tuple(sorted(files, key=lambda f: f.path)),
            labels=self.labels.to_dict(),
        )

    def __enter__(self) -> ClipWriter:
        return self

    def __exit__(self, kind, error, traceback) -> None:
        if kind is not None:
            self._stream.abort()


def write_clip(
    root: Path, format: str, frames: Iterable[LabelledFrame], sensors: Sequence[Sensor], clip_index: int
) -> ClipRecord:
    """Write one clip's frames (any iterable: a generator streams) under `root`, each file atomically;
    returns what `finish_dataset` needs."""
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        dataset_format(format)  # an unknown format is said first
        raise UserError(f"clip index {clip_index}: no frames to write")
    check_frame(first.clip, 0, first)
    with ClipWriter(root, format, first.clip, clip_index, sensors) as writer:
        for frame in itertools.chain([first], frames):
            writer.add(frame)
        return writer.close()


def finish_dataset(
    root: Path, format: str, clips: Sequence[ClipRecord], sensors: Sequence[Sensor], scenario: Mapping, seed: int
) -> Manifest:
    """Write the format's dataset files (its `finish`: the ImageSets of KITTI and OpenPCDet, KITTI's
    placeholder images if `scenario["dataset"]["kitti_images"]`, Parquet's sensors and units tables),
    README.md and, last, manifest.json."""
    root = Path(root)
    plugin = dataset_format(format)
    clips = sorted(clips, key=lambda c: c.clip_index)
    if not clips:
        raise UserError(f"{root}: no clips written, nothing to finish")
    for kind, key in (("clip index", "clip_index"), ("clip id", "clip")):
        values = [getattr(c, key) for c in clips]
        if len(set(values)) != len(values):
            raise UserError(f"{root}: two clips have the same {kind}")
    written_as = {c.format for c in clips}
    if written_as != {plugin.name}:
        raise UserError(f"{root}: clips written as {sorted(written_as)}, finishing as {format}")
    files = [f for c in clips for f in c.files] + plugin.finish(root, clips, sensors, scenario)
    val = val_clips([c.clip_index for c in clips])
    statistics = LabelStatistics.empty()
    for clip in clips:
        statistics = statistics.merged(LabelStatistics.from_dict(clip.labels))
    manifest = Manifest(
        format=format,
        schema_version=SCHEMA_VERSION,
        simgen_version=__version__,
        dependencies=dependency_versions(),
        scenario=dict(scenario),
        seed=seed,
        sensors=tuple(sorted(sensors, key=lambda s: s.sensor_id)),
        clips=tuple(
            ClipEntry(
                c.clip, c.clip_index, c.frames, c.points, c.boxes, "val" if c.clip_index in val else "train", c.start_s
            )
            for c in clips
        ),
        files=tuple(sorted(files, key=lambda f: f.path)),
        labels=statistics.summary(),
    )
    write_card(root, manifest)  # first: a dataset whose manifest exists always has its card
    write_bytes(root, MANIFEST_NAME, manifest_bytes(manifest), len(manifest.files))
    return manifest


def write_card(root: Path, manifest: Manifest) -> None:
    """The dataset card, README.md, from the manifest."""
    write_bytes(Path(root), CARD_NAME, dataset_card(manifest).encode(), 0)
