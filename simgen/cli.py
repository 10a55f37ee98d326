"""`simgen` command line: one sub-command per module in `simgen.commands`.

Each command module exposes `register(subparsers)`, which adds its parser and sets
`func(args) -> int` as the parser's default. Bad input raises `UserError`, which is
reported here as one line and exit code 2.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import sys

from simgen import __version__
from simgen.errors import UserError

COMMANDS = (
    "capture", "generate", "validate", "pattern", "qa", "coverage", "view", "verify", "export", "pack", "unpack"
)
#: What the disk or the file system can refuse any command that writes: one line and exit 2, not a traceback.
DISK_ERRORS = {
    errno.ENOSPC: "no space left on the device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "file too large for the file system or the process's limit",
    errno.EIO: "input/output error (a failing disk or network file system)",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EROFS: "read-only file system",
}


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors are one line (argparse already exits 2)."""

    def error(self, message: str) -> None:
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="simgen",
        description="Simulate a sparse, stationary Livox LiDAR watching a football match "
        "played by the Google Research Football engine, and write labelled datasets.",
    )
    parser.add_argument("--version", action="version", version=f"simgen {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    subparsers.required = True
    for name in COMMANDS:
        importlib.import_module(f"simgen.commands.{name}").register(subparsers)
    return parser


def dispatch(prog: str, args: argparse.Namespace) -> int:
    """Run a parsed sub-command: `UserError` becomes one line on stderr and exit code 2."""
    try:
        return int(args.func(args) or 0)
    except UserError as error:
        print(f"{prog} {args.command}: error: {' '.join(str(error).splitlines())}", file=sys.stderr)
        return 2
    except OSError as error:
        if error.errno not in DISK_ERRORS:
            raise
        filename = error.filename or getattr(args, "output", None)
        where = f"{filename}: " if filename else ""
        hint = (
            " (files written so far are whole; `generate --resume` finishes a run)"
            if args.command == "generate"
            else ""
        )
        print(f"{prog} {args.command}: error: {where}{DISK_ERRORS[error.errno]}{hint}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog} {args.command}: interrupted", file=sys.stderr)
        return 130


def main(argv: list[str] | None = None) -> int:
    return dispatch("simgen", build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
