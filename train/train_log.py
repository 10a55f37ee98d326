"""A fit's train_log.csv: a row every `train.log_every` iterations, appended and flushed row by row (a
reader can follow it), never rewritten, and on disk (fsync) whenever a checkpoint is saved, so every row
up to a checkpoint's iteration outlives a crash.

A resumed fit checks its log against its checkpoint before it trains (`check_log`): every row up to
the checkpoint's iteration must be there, whole and in order (else one `UserError` line); what follows
them, rows a killed fit wrote after its last checkpoint (written again as the fit goes on), is cut off
once it starts (`continued_log`), and a torn last row among it is reported.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from simgen.errors import UserError

LINE_BYTES = 4096  # a line longer than this is no row of ours
DAMAGED = "the log is damaged (--overwrite starts the run again)"


def log_fields(tracklet_boxes: int) -> list[str]:
    """The log's columns for a head that predicts `tracklet_boxes` boxes a tracklet."""
    return ["iteration", "seconds", "samples_per_s", "lr", "loss", "loss_cls", "loss_dir"] + [
        f"loss_loc_{k}" for k in range(tracklet_boxes)
    ]


def _header(fields: list[str]) -> bytes:
    return (",".join(fields) + "\r\n").encode()  # csv's own line ending, as every row


def _row(line: bytes, columns: int) -> list[float] | None:
    """A whole row's values (a line csv wrote, its ending included), or None."""
    if not line.endswith(b"\r\n"):
        return None
    try:
        values = [float(v) for v in line[:-2].decode("ascii").split(",")]
    except (UnicodeDecodeError, ValueError):
        return None
    return values if len(values) == columns and values[0].is_integer() else None


class TrainLog:
    """An open log, appended to row by row."""

    def __init__(self, file: TextIO, fields: list[str]):
        self._file = file
        self._writer = csv.DictWriter(file, fieldnames=fields)

    def append(self, row: dict[str, object]) -> None:
        """One row, flushed (a reader can follow it)."""
        self._writer.writerow(row)
        self._file.flush()

    def sync(self) -> int:
        """The rows written so far, on disk (before a checkpoint that follows them is); the log's length in bytes."""
        self._file.flush()
        os.fsync(self._file.fileno())
        return os.fstat(self._file.fileno()).st_size

    def close(self) -> None:
        self._file.close()


def new_log(path: Path, fields: list[str]) -> TrainLog:
    """A fresh log holding its header."""
    file = open(path, "w", newline="")
    file.write(_header(fields).decode())
    log = TrainLog(file, fields)
    log.sync()
    return log


@dataclass(frozen=True)
class CheckedLog:
    """A resumed fit's log as checked against its checkpoint."""

    path: Path
    end: int  # bytes: where the row of the checkpoint's iteration (or the last before it) ends
    losses: list[tuple[int, float]]  # (iteration, loss) of the rows up to there
    torn: bool  # whether a torn last row follows them


def check_log(path: Path, fields: list[str], until: int, log_bytes: int | None, log_every: int) -> CheckedLog:
    """The log of a fit to be resumed at iteration `until`, read and checked, not changed: one `UserError`
    line unless its header and every row up to `until` are there, whole and in order. Where those rows end:
    `log_bytes` (the checkpoint's record), or, for a checkpoint without it, after the row of every
    `log_every`-th iteration up to `until`."""
    if not path.is_file():
        raise UserError(f"{path}: missing or not a file; a resumed fit goes on with its log (--overwrite starts the "
                        "run again)")
    losses: list[tuple[int, float]] = []
    with open(path, "rb") as file:
        if file.readline(LINE_BYTES) != _header(fields):
            raise UserError(f"{path}: its first line is not this training's header; {DAMAGED}")
        while file.tell() < log_bytes if log_bytes is not None else len(losses) < until // log_every:
            values = _row(file.readline(LINE_BYTES), len(fields))
            previous = losses[-1][0] if losses else 0
            wanted = values is not None and previous < values[0] <= until and (
                log_bytes is not None or values[0] == previous + log_every)
            if not wanted or (log_bytes is not None and file.tell() > log_bytes):
                raise UserError(f"{path}: line {len(losses) + 2} is not a whole row of an iteration after "
                                f"{previous:,}, up to the checkpoint's {until:,}; {DAMAGED}")
            losses.append((int(values[0]), values[fields.index("loss")]))
        end, size = file.tell(), os.fstat(file.fileno()).st_size
        torn = False
        if size > end:
            file.seek(size - 1)
            torn = file.read(1) != b"\n"
    return CheckedLog(path, end, losses, torn)


def continued_log(checked: CheckedLog, fields: list[str]) -> TrainLog:
    """The checked log cut after its rows up to the checkpoint (what follows is written again) and open to
    append."""
    os.truncate(checked.path, checked.end)
    return TrainLog(open(checked.path, "a", newline=""), fields)
