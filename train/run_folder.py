"""A fit's output folder: one writer at a time, no run replaced unasked, nothing left by a refused fit.

- While a fit writes, it holds an `flock` on LOCK_NAME, a file holding its pid; the kernel releases it
  when the holder dies, and a second writer is refused in one line. The file goes when the fit ends.
- A folder holds a run when it has a checkpoint or a log: a fit refuses it unless it resumes it
  (`--resume`) or replaces it (`--overwrite`, which removes that run's files and nothing else, once
  every check has passed).
- A killed writer's temporary files (`.checkpoint.pt.tmp-PID`, ...) are removed when the next one starts.
- A fresh fit that fails before its first checkpoint removes its files, and the folders it made.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path
from types import TracebackType

from simgen.errors import UserError
from train.evaluation.learning_curve import CSV_NAME, PNG_NAME

CHECKPOINT_NAME = "checkpoint.pt"
LOG_NAME = "train_log.csv"
LOCK_NAME = ".lock"
RUN_FILES = (CHECKPOINT_NAME, LOG_NAME, CSV_NAME, PNG_NAME)  # what a fit writes, and --overwrite removes


class RunFolder:
    """`with RunFolder(out, resume, overwrite):` holds OUT for one fit; `start()` once it is to train."""

    def __init__(self, out: Path, resume: bool, overwrite: bool):
        if resume and overwrite:
            raise UserError("--resume and --overwrite contradict each other; choose one")
        self.out, self.resume, self.overwrite = out, resume, overwrite
        self._started = False

    def __enter__(self) -> RunFolder:
        out = self.out
        self._made = [p for p in (out, *out.absolute().parents) if not p.exists()]
        out.mkdir(parents=True, exist_ok=True)
        try:
            self._lock = _lock(out)
            for name in RUN_FILES:  # no other writer is alive: what one never renamed is stale
                for stale in out.glob(f".{name}.tmp-*"):
                    stale.unlink()
            for name in RUN_FILES:  # what --resume reads and --overwrite removes
                if (out / name).exists() and not (out / name).is_file():
                    raise UserError(f"{out / name}: not a regular file, as a run's {name} is; move it out")
            held = [name for name in (CHECKPOINT_NAME, LOG_NAME) if (out / name).exists()]
            if held and not (self.resume or self.overwrite):
                raise UserError(f"{out}: holds a training run ({held[0]}); --resume continues it, --overwrite "
                                "replaces it")
            if self.resume and not (out / CHECKPOINT_NAME).is_file():
                raise UserError(f"{out}: no {CHECKPOINT_NAME} to resume from; --overwrite starts the run again")
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def start(self) -> None:
        """Every check has passed and training begins: with `overwrite`, remove the earlier run's files."""
        if self.overwrite:
            for name in RUN_FILES:
                (self.out / name).unlink(missing_ok=True)
        self._started = True

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        failed = kind is not None or not self._started
        if failed and self._started and not self.resume and not (self.out / CHECKPOINT_NAME).exists():
            for name in RUN_FILES:
                (self.out / name).unlink(missing_ok=True)
        lock = getattr(self, "_lock", None)
        if lock is not None:
            (self.out / LOCK_NAME).unlink(missing_ok=True)  # while still held: no one locks a file on its way out
            os.close(lock)
            self._lock = None
        if failed:
            for folder in self._made:  # deepest first; each only if empty
                try:
                    folder.rmdir()
                except OSError:
                    break


def _lock(out: Path) -> int:
    """An exclusive flock on OUT/LOCK_NAME, which then holds this process's pid; its descriptor."""
    path = out / LOCK_NAME
    while True:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = " ".join(os.read(descriptor, 200).decode(errors="replace").split()) or "another process"
            os.close(descriptor)
            raise UserError(f"{out}: another simgen-train fit is writing here ({holder}); wait for it or use "
                            "another -o") from None
        try:
            current = os.stat(path, follow_symlinks=False).st_ino == os.fstat(descriptor).st_ino
        except FileNotFoundError:
            current = False
        if current:
            break
        os.close(descriptor)  # its holder removed it as it finished: lock the file now there
    os.ftruncate(descriptor, 0)
    os.write(descriptor, f"pid {os.getpid()} on {os.uname().nodename}\n".encode())
    return descriptor
