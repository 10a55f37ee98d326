"""What a writer hands back: each file it wrote (path, rows, bytes, sha256) and each clip's totals.

Files are written atomically (temporary name beside the target, then rename), so a crash never
leaves a partial file under a final name. Records are plain data (`to_dict` / `from_dict` give
JSON), so clips written by other processes come back to the one that writes the manifest.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass
from pathlib import Path

from simgen.atomic import atomic_path

CHUNK_BYTES = 1 << 20


@dataclass(frozen=True)
class FileRecord:
    """One written file, its path relative to the dataset root (POSIX separators)."""

    path: str
    rows: int  # points, boxes, frames or text lines, as the format counts them
    bytes: int
    sha256: str


@dataclass(frozen=True)
class ClipRecord:
    """One written clip: its name, index, totals and files."""

    format: str
    clip: str
    clip_index: int
    frames: int
    points: int
    boxes: int
    start_s: float  # game time of the first written frame's sweep start (frame 0's for a whole clip)
    files: tuple[FileRecord, ...]
    labels: dict  # simgen.labels.statistics.LabelStatistics.to_dict() of its frames

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> ClipRecord:
        return cls(**{**data, "files": tuple(FileRecord(**f) for f in data["files"])})


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        while chunk := stream.read(CHUNK_BYTES):
            digest.update(chunk)
    return digest.hexdigest()


def record_file(root: Path, relative: str, rows: int) -> FileRecord:
    """Record a file already written under `root`."""
    path = root / relative
    return FileRecord(relative, rows, path.stat().st_size, sha256_file(path))


def write_bytes(root: Path, relative: str, data: bytes, rows: int) -> FileRecord:
    """Write `data` atomically to `root / relative` (creating its directory) and record it."""
    path = root / relative
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return FileRecord(relative, rows, len(data), hashlib.sha256(data).hexdigest())


def write_text(root: Path, relative: str, lines: list[str]) -> FileRecord:
    """Write lines (each ended by a newline) atomically; rows = lines."""
    return write_bytes(root, relative, "".join(f"{line}\n" for line in lines).encode(), len(lines))
