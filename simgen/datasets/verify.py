"""The reader's only way to a file: named in the manifest, and its sha256 checked on first use.

A flipped byte anywhere in a shard, a .bin or a label file is a one-line `UserError` naming the
file before any of it is read as data. A `Problem` is what `simgen verify` reports: a file, a row, what is wrong.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from simgen.datasets.records import FileRecord, sha256_file
from simgen.errors import UserError


class DatasetFiles:
    """The files of a dataset, checked against the manifest's size and sha256 the first time each is used."""

    def __init__(self, root: Path, records: list[FileRecord], verify: bool = True):
        self.root = root
        self.records = {record.path: record for record in records}
        self.verify = verify
        self._checked: set[str] = set()

    def _record(self, relative: str) -> FileRecord:
        record = self.records.get(relative)
        if record is None:
            raise UserError(f"{self.root / relative}: not in the dataset's manifest.json")
        path = self.root / relative
        if not path.is_file():
            raise UserError(f"{path}: missing (listed in manifest.json)")
        if relative not in self._checked and not path.resolve().is_relative_to(self.root.resolve()):
            raise UserError(f"{path}: a link that leaves the dataset")
        return record

    def _check(self, relative: str, size: int, digest: str) -> None:
        record = self.records[relative]
        if size != record.bytes:
            raise UserError(
                f"{self.root / relative}: {size} bytes, manifest.json says {record.bytes} (truncated or replaced)"
            )
        if digest != record.sha256:
            raise UserError(f"{self.root / relative}: sha256 differs from manifest.json (corrupt or modified)")
        self._checked.add(relative)

    def path(self, relative: str) -> Path:
        """The file's path, its checksum verified (once)."""
        self._record(relative)  # refuses a file the manifest does not list
        path = self.root / relative
        if self.verify and relative not in self._checked:
            self._check(relative, path.stat().st_size, sha256_file(path))
        return path

    def read(self, relative: str) -> bytes:
        """The file's bytes, their checksum verified (once)."""
        self._record(relative)
        data = (self.root / relative).read_bytes()
        if self.verify and relative not in self._checked:
            self._check(relative, len(data), hashlib.sha256(data).hexdigest())
        return data

    def rows(self, relative: str) -> int:
        return self._record(relative).rows

    def verify_all(self) -> None:
        """Check every file of the manifest now, whether or not `verify` is on."""
        for relative in sorted(self.records):
            path = self.root / self._record(relative).path
            self._check(relative, path.stat().st_size, sha256_file(path))


@dataclass(frozen=True)
class Problem:
    """Something wrong in a dataset, at a file and, for labels, a row."""

    file: str  # the file's path
    row: int | None  # line number (1-based) in a text file, row index (0-based) in a Parquet table
    message: str

    def __str__(self) -> str:
        where = self.file if self.row is None else f"{self.file}:{self.row}"
        return f"{where}: {self.message}"
