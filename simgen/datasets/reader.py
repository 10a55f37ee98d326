"""`open(path)`: frames by clip and index, and sequences of consecutive frames, in every format.

The format comes from manifest.json; every file is checked against its sha256 there the first
time it is read (`verify=False` skips that; `Dataset.verify()` checks them all at once).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path

from simgen.datasets.formats import dataset_format
from simgen.datasets.frame import Frame, frame_times
from simgen.datasets.manifest import MANIFEST_NAME, ClipEntry, Manifest, read_manifest
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError


def check_files_match_clips(root: Path, manifest: Manifest) -> None:
    """The files listed are exactly those of the clips' frames and the format's dataset files, and the
    rows listed for a clip's files fit its frames: a lowered frame count cannot hide frames."""
    plugin = dataset_format(manifest.format)
    listed = {f.path: f for f in manifest.files}
    expected = plugin.dataset_files(manifest)
    where = root / MANIFEST_NAME
    for entry in manifest.clips:
        files = plugin.clip_files(entry)
        missing = sorted(files - set(listed))
        if missing:
            raise UserError(f"{where}: clip {entry.clip} has {entry.frames} frames, but {missing[0]} is not listed")
        problem = plugin.listed_rows_problem(entry, listed, len(manifest.sensors))
        if problem:
            raise UserError(f"{where}: {problem}")
        expected |= files
    missing = sorted(expected - set(listed))
    if missing:
        raise UserError(f"{where}: {missing[0]} is not listed")
    extra = sorted(set(listed) - expected)
    if extra:
        raise UserError(
            f"{where}: {extra[0]} belongs to no listed clip frame "
            f"(frames: {', '.join(f'{c.clip} {c.frames}' for c in manifest.clips[:3])})"
        )


class Dataset:
    """A written dataset: `clips`, `num_frames(clip)`, `frame(clip, index)`, `sequence(...)`, iteration."""

    def __init__(self, root: Path, manifest: Manifest, verify: bool = True):
        self.root = root
        self.manifest = manifest
        self.format = manifest.format
        self.plugin = dataset_format(manifest.format)  # what the format writes, reads and carries
        check_files_match_clips(root, manifest)
        self.files = DatasetFiles(root, list(manifest.files), verify)
        self._clips = {c.clip: c for c in manifest.clips}
        self._reader = self.plugin.reader(self.files, manifest)

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
            rate_hz = self.manifest.sensors[0].frame_rate_hz
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
