"""A fit's train_log.csv: a row every `train.log_every` iterations, appended and flushed row by row (a
reader can follow it), never rewritten, and on disk (fsync) whenever a checkpoint is saved, so every row
up to a checkpoint's iteration outlives a crash.

A resumed fit checks its log against its checkpoint before it trains: every row up to the checkpoint's
iteration must be there, whole and in order (else one `UserError` line); what follows them, rows a killed
fit wrote after its last checkpoint (written again as the fit goes on), is cut off, and a torn last row
among it is reported.
"""

from __future__ import annotations

import csv
import math
import os
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
    return values if len(values) == columns and all(map(math.isfinite, values)) else None


class TrainLog:
    """An open log, appended to row by row."""

    def __init__(self, file: TextIO, fields: list[str]):
        self._file = file
        self._writer = csv.DictWriter(file, fieldnames=fields)

    def append(self, row: dict[str, object]) -> None:
        """One row, flushed (a reader can follow it)."""
        self._writer.writerow(row)
        self._file.flush()

    def sync(self) -> None:
        """The rows written so far, on disk (before a checkpoint that follows them is)."""
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        self._file.close()


def new_log(path: Path, fields: list[str]) -> TrainLog:
    """A fresh log holding its header."""
    file = open(path, "w", newline="")
    file.write(_header(fields).decode())
    log = TrainLog(file, fields)
    log.sync()
    return log


def resumed_log(path: Path, fields: list[str], until: int, log_every: int) -> tuple[
        TrainLog, list[tuple[int, float]], bool]:
    """The log of a fit resumed at iteration `until`, cut after its row of that iteration (or the last
    one before it) and open to append.

    Returns:
        the log, (iteration, loss) of the rows kept, and whether a torn last row was cut off.
    """
    if not path.is_file():
        raise UserError(f"{path}: missing or not a file; a resumed fit goes on with its log (--overwrite starts the "
                        "run again)")
    losses = []
    with open(path, "rb") as file:
        if file.readline(LINE_BYTES) != _header(fields):
            raise UserError(f"{path}: its first line is not this training's header; {DAMAGED}")
        for iteration in range(log_every, until + 1, log_every):
            values = _row(file.readline(LINE_BYTES), len(fields))
            if values is None or values[0] != iteration:
                raise UserError(f"{path}: line {len(losses) + 2} is not the whole row of iteration {iteration:,} "
                                f"(the checkpoint is at {until:,}); {DAMAGED}")
            losses.append((iteration, values[fields.index("loss")]))
        end, size = file.tell(), os.fstat(file.fileno()).st_size
        torn = False
        if size > end:
            file.seek(size - 1)
            torn = file.read(1) != b"\n"
    os.truncate(path, end)
    return TrainLog(open(path, "a", newline=""), fields), losses, torn
