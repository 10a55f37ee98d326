"""`open(path)`: frames by clip and index, and sequences of consecutive frames, in every format.

The format comes from manifest.json; every file is checked against its sha256 there the first
time it is read (`verify=False` skips that; `Dataset.verify()` checks them all at once).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path

from simgen.datasets import kitti, openpcdet, ros2_bag
from simgen.datasets.frame import Frame, frame_times
from simgen.datasets.kitti import KittiReader
from simgen.datasets.manifest import MANIFEST_NAME, ClipEntry, Manifest, read_manifest
from simgen.datasets.openpcdet import OpenPCDetReader
from simgen.datasets.parquet import SENSORS_PATH, UNITS_PATH, ParquetReader, table_path
from simgen.datasets.ros2_bag import BagReader
from simgen.datasets.schema import CLIP_TABLES
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError

IMAGE_SETS = ("ImageSets/train.txt", "ImageSets/val.txt", "ImageSets/trainval.txt")


def clip_files(format: str, entry: ClipEntry) -> set[str]:
    """Relative paths of every file a clip's frames are read from."""
    if format == "parquet":
        return {table_path(name, entry.clip) for name in CLIP_TABLES}
    if format == "mcap":
        return {ros2_bag.bag_path(entry.clip)}
    frames = range(entry.frames)
    if format == "openpcdet":
        return {f(entry.clip_index, i) for i in frames for f in (openpcdet.points_path, openpcdet.labels_path)}
    tracking = format == "kitti_tracking"
    paths = (kitti.velodyne_path, kitti.label_path, kitti.calib_path)
    placements = {kitti.placements_path(entry.clip_index)} if tracking else set()
    return {f(tracking, entry.clip_index, i) for i in frames for f in paths} | placements


def check_files_match_clips(root: Path, manifest: Manifest) -> None:
    """The files listed are exactly those of the clips' frames (and the ImageSets), and a Parquet clip's
    `frames` table has as many rows as the clip has frames: a lowered frame count cannot hide frames."""
    listed = {f.path: f for f in manifest.files}
    expected = set(IMAGE_SETS) if manifest.format in ("kitti", "openpcdet") else set()
    if manifest.format == "parquet":
        expected |= {SENSORS_PATH, UNITS_PATH}
    if manifest.format == "kitti" and manifest.scenario.get("dataset", {}).get("kitti_images"):
        expected |= {kitti.image_path(c.clip_index, i) for c in manifest.clips for i in range(c.frames)}
    where = root / MANIFEST_NAME
    for entry in manifest.clips:
        files = clip_files(manifest.format, entry)
        missing = sorted(files - set(listed))
        if missing:
            raise UserError(f"{where}: clip {entry.clip} has {entry.frames} frames, but {missing[0]} is not listed")
        if manifest.format == "parquet" and listed[table_path("frames", entry.clip)].rows != entry.frames:
            rows = listed[table_path("frames", entry.clip)].rows
            raise UserError(f"{where}: clip {entry.clip} lists {entry.frames} frames, its frames table {rows}")
        if manifest.format == "mcap" and listed[ros2_bag.bag_path(entry.clip)].rows != ros2_bag.bag_messages(entry.frames, len(manifest.sensors)):
            rows = listed[ros2_bag.bag_path(entry.clip)].rows
            raise UserError(f"{where}: clip {entry.clip} lists {entry.frames} frames, its bag {rows} messages")
        expected |= files
    missing = sorted(expected - set(listed))
    if missing:
        raise UserError(f"{where}: {missing[0]} is not listed")
    extra = sorted(set(listed) - expected)
    if extra:
        raise UserError(f"{where}: {extra[0]} belongs to no listed clip frame (frames: {', '.join(f'{c.clip} {c.frames}' for c in manifest.clips[:3])})")


class Dataset:
    """A written dataset: `clips`, `num_frames(clip)`, `frame(clip, index)`, `sequence(...)`, iteration."""

    def __init__(self, root: Path, manifest: Manifest, verify: bool = True):
        self.root = root
        self.manifest = manifest
        self.format = manifest.format
        check_files_match_clips(root, manifest)
        self.files = DatasetFiles(root, list(manifest.files), verify)
        self._clips = {c.clip: c for c in manifest.clips}
        indices = {c.clip: c.clip_index for c in manifest.clips}
        if self.format == "parquet":
            self._reader = ParquetReader(self.files)
        elif self.format == "openpcdet":
            self._reader = OpenPCDetReader(self.files, indices)
        elif self.format == "mcap":
            self._reader = BagReader(self.files, manifest.sensors)
        else:
            self._reader = KittiReader(self.files, indices, tracking=self.format == "kitti_tracking")

    def __repr__(self) -> str:
        frames = sum(c.frames for c in self.manifest.clips)
        return f"Dataset({str(self.root)!r}: {self.manifest.format}, {len(self.manifest.clips)} clips, {frames} frames)"

    @property
    def clips(self) -> tuple[str, ...]:
        """Clip ids in clip-index order."""
        return tuple(self._clips)

    def split(self, clip: str) -> str:
        """`train` or `val`."""
        return self._entry(clip).split

    def num_frames(self, clip: str) -> int:
        return self._entry(clip).frames

    def _entry(self, clip: str) -> ClipEntry:
        entry = self._clips.get(clip)
        if entry is None:
            more = ", ..." if len(self.clips) > 5 else ""
            raise UserError(f"{self.root}: no clip {clip!r} (clips: {', '.join(self.clips[:5])}{more})")
        return entry

    def frame(self, clip: str, index: int) -> Frame:
        frames = self.num_frames(clip)
        if not 0 <= index < frames:
            raise UserError(f"{self.root}: clip {clip} has frames 0-{frames - 1}, not {index}")
        frame = self._reader.frame(clip, index)
        if frame.time_s is None:  # KITTI and OpenPCDet files keep no time: the manifest's clock
            rate_hz = float(self.manifest.sensors[0]["frame_rate_hz"])
            time_s, label_time_s = frame_times(self._entry(clip).start_s, rate_hz, index)
            frame = dataclasses.replace(frame, time_s=time_s, label_time_s=label_time_s)
        return frame

    def sequence(self, clip: str, index: int, length: int = 3) -> list[Frame]:
        """`length` consecutive frames of `clip` ending at `index`, oldest first."""
        if length < 1 or index - length + 1 < 0:
            raise UserError(f"{self.root}: clip {clip} has no {length} frames ending at frame {index}")
        return [self.frame(clip, i) for i in range(index - length + 1, index + 1)]

    def __len__(self) -> int:
        return sum(c.frames for c in self._clips.values())

    def __iter__(self) -> Iterator[Frame]:
        for clip in self.clips:
            for index in range(self.num_frames(clip)):
                yield self.frame(clip, index)

    def verify(self) -> None:
        """Check every file's size and sha256 against the manifest now."""
        self.files.verify_all()


def open_dataset(path: str | Path, verify: bool = True) -> Dataset:
    """Open a dataset that simgen wrote, in any of its formats."""
    root = Path(path)
    manifest = read_manifest(root)
    return Dataset(root, manifest, verify)
