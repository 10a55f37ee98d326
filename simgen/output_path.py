"""Every command's `-o`, checked before any work: one line naming what is wrong with it, never a device replaced.

An atomic write renames a temporary file over its target, whatever the target is: over /dev/null it
leaves a regular file where the device was. A reader writing into the dataset it reads destroys it.
`check_output` refuses both, and every other output that cannot end well, before the command
reads or computes anything (stdlib only, so that `simgen unpack` stays light).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Literal

from simgen.atomic import check_output_allowed
from simgen.errors import UserError

#: Pseudo file systems: nothing a command writes belongs there.
SYSTEM_TREES = (Path("/proc"), Path("/sys"))

_KINDS = {
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFIFO: "a FIFO",
    stat.S_IFSOCK: "a socket",
}


def check_output(
    path: str | Path,
    kind: Literal["file", "folder"],
    reads: Iterable[str | Path] = (),
    new: bool = False,
    replaces: bool = False,
) -> Path:
    """Refuse, as a one-line `UserError`, an output `path` that would destroy or could not hold what a command writes.

    Refused: a dangling link; a device node, FIFO or socket (or a link to one); a folder where a file is
    written (`kind="file"`) or a file where a folder is (`kind="folder"`); anything that exists when `new`;
    a path under /proc or /sys, below a file, or whose nearest existing folder is not writable; a path
    equal to or inside any of `reads` (the datasets, runs and files the command reads), or, when `replaces`, one
    of `reads` inside `path` (replacing what `path` holds would delete it); outside
    $SIMGEN_OUTPUT_ROOTS when that is set. Folders missing between the nearest existing one and `path`
    are allowed (commands create them).

    Args:
        path: the `-o` as given.
        kind: what the command writes there: one file, or a folder of files.
        reads: what the command reads (folders or files); the output may not lie in or on one.
        new: the command creates `path` and refuses to replace it (pack, unpack).
        replaces: the command may delete what `path` holds (generate --overwrite).
    Returns:
        `path` as a `Path`.
    """
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise UserError(f"{path}: a link to {os.readlink(path)}, which does not exist")
    target = path.resolve()
    if any(target == tree or tree in target.parents for tree in SYSTEM_TREES):
        raise UserError(f"{path}: under {next(t for t in SYSTEM_TREES if t == target or t in target.parents)}, "
                        f"a system file system, not an output")
    for read in reads:
        source = Path(read).resolve()
        if target == source or source in target.parents:
            raise UserError(f"{path}: inside {read}, which this command reads (write elsewhere)")
        if replaces and target in source.parents:
            raise UserError(f"{path}: holds {read}, which this command reads; replacing {path} would delete it "
                            "(move it out)")
    if path.exists():
        mode = path.stat().st_mode
        if stat.S_IFMT(mode) in _KINDS:
            raise UserError(f"{path}: {_KINDS[stat.S_IFMT(mode)]}, not a {kind} simgen may write")
        if new:
            raise UserError(f"{path}: already exists")
        if kind == "file" and stat.S_ISDIR(mode):
            raise UserError(f"{path}: is a directory, expected a file name")
        if kind == "folder" and not stat.S_ISDIR(mode):
            raise UserError(f"{path}: exists and is not a directory")
    _check_parent(path, target)
    check_output_allowed(path)
    return path


def _check_parent(path: Path, target: Path) -> None:
    """The nearest existing folder above `target` is a writable folder, not a file."""
    parent = target.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise UserError(f"{path}: below {parent}, which is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        if os.statvfs(parent).f_flag & os.ST_RDONLY:
            raise UserError(f"{path}: read-only file system")  # as the CLI says it when a write is refused
        raise UserError(f"{path}: {parent} is not a writable folder")
