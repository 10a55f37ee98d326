"""Atomic file output: write under a temporary name beside the target, then rename.

A crash or bad input never leaves a half-written file under the final name.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from simgen.errors import UserError


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; rename it to `path` on success."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a directory, expected a file name")
    if not path.parent.is_dir():
        raise UserError(f"{path.parent}: output directory does not exist")
    if not os.access(path.parent, os.W_OK):
        raise UserError(f"{path.parent}: output directory is not writable")
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
