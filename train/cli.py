"""`simgen-train`: detection and tracking on simgen datasets.

The detector, tracker and metrics land here as sub-commands (`fit`, `eval`, `detect`); until then
this entry point only explains itself.
"""

from __future__ import annotations

import argparse
import sys


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="simgen-train",
        description="Train and evaluate the paper's PointPillars tracklet detector and 3D DIoU tracker "
        "on datasets written by `simgen generate`, read through simgen.datasets.",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    parser.parse_args(argv)
    parser.print_help(sys.stderr)
    print("simgen-train: error: no training commands are available in this version yet", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
