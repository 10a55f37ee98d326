"""Atomic file output: write under a temporary name beside the target, then rename.

A crash or bad input never leaves a half-written file under the final name.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from simgen.errors import UserError


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's directory; rename it to `path` on success."""
    path = Path(path)
    check_output_allowed(path)
    if path.is_dir():
        raise UserError(f"{path}: is a directory, expected a file name")
    if path.exists() and not path.is_file():  # the rename would put a regular file where a device was
        raise UserError(f"{path}: not a regular file, refusing to replace it")
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


OUTPUT_ROOTS_ENV = "SIMGEN_OUTPUT_ROOTS"


def check_output_allowed(path: str | Path) -> None:
    """Refuse outputs outside the directories listed in $SIMGEN_OUTPUT_ROOTS (colon-separated), if set.

    Dataset builders on shared machines set it to the shared data roots, so that a mistyped -o
    never writes into a home or system directory.
    """
    roots = [Path(r).resolve() for r in os.environ.get(OUTPUT_ROOTS_ENV, "").split(":") if r]
    if not roots:
        return
    target = Path(path).resolve()
    if not any(target == root or root in target.parents for root in roots):
        allowed = ", ".join(map(str, roots))
        raise UserError(f"{path}: outside the allowed output roots ({OUTPUT_ROOTS_ENV}={allowed})")
