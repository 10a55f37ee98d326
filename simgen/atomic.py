"""Atomic file output: write under a temporary name beside the target, then rename.

A crash or bad input never leaves a half-written file under the final name.
"""

from __future__ import annotations

import contextlib
import os
import shutil
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


@contextlib.contextmanager
def atomic_directory(path: str | Path, name: str, replace: bool = False) -> Iterator[Path]:
    """Yield `<temporary directory beside path>/<name>`, not yet created; move it to `path` on success.

    For writers that create their directory themselves and name files inside after it (rosbags' bag
    `Writer`). `replace`: an existing directory `path` is replaced (else an error naming it).
    """
    path = Path(path)
    check_output_allowed(path)
    if not (replace and path.is_dir()):
        check_new(path)
    if not path.parent.is_dir():
        raise UserError(f"{path.parent}: output directory does not exist")
    if not os.access(path.parent, os.W_OK):
        raise UserError(f"{path.parent}: output directory is not writable")
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.mkdir()
    try:
        yield tmp / name
        if path.exists():
            os.replace(path, tmp / f"{name}.old")
        os.replace(tmp / name, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def check_new(path: Path) -> None:
    """Refuse an output (a bag directory, a LAS file) that exists already."""
    if path.exists():
        raise UserError(f"{path}: exists already; give a new name")


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
