"""What the sub-commands share: a parser with a wrapped description, and the common arguments."""

from __future__ import annotations

import argparse
import functools
import textwrap
from collections import UserString
from collections.abc import Callable
from pathlib import Path

from simgen.errors import UserError


class LazyText(UserString):
    """Help text made only when shown (e.g. a list that needs heavy imports), so that `simgen --help`
    stays fast; argparse uses it as a string."""

    def __init__(self, make: Callable[[], str]):
        self._make = functools.cache(make)

    @property
    def data(self) -> str:  # UserString's methods read `data`
        return self._make()


def add_command(subparsers, name: str, summary: str, description: str) -> argparse.ArgumentParser:
    """A sub-command's parser: `summary` in `simgen --help`, `description` wrapped at 88 columns in its own."""
    return subparsers.add_parser(
        name,
        help=summary,
        description=textwrap.fill(description, width=88),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def add_scenario_arguments(parser: argparse.ArgumentParser, output_help: str, frames_help: str) -> None:
    """SCENARIO, -o OUTPUT, --frames and --seed, as `capture` and `generate` take them."""
    parser.add_argument("scenario", type=Path, help="scenario YAML file (see scenarios/)")
    parser.add_argument("-o", "--output", type=Path, required=True, help=output_help)
    parser.add_argument("--frames", type=int, help=frames_help)
    parser.add_argument("--seed", type=int, help="random seed (default: the scenario's)")


def add_dataset_argument(parser: argparse.ArgumentParser, **kwargs) -> None:
    """DATASET, a directory that simgen wrote (the commands that read datasets)."""
    parser.add_argument(
        "dataset", type=Path, metavar="DATASET", help="dataset directory (with manifest.json)", **kwargs
    )


def frame_range(text: str, frames: int, option: str = "--frames") -> range:
    """Frames of `A:B` (either may be left out) or `A`, within 0..frames-1; bad ones are a `UserError` naming
    `option`."""
    try:
        if ":" in text:
            start_text, stop_text = text.split(":", 1)
            start = int(start_text) if start_text.strip() else 0
            stop = int(stop_text) if stop_text.strip() else frames
        else:
            start = int(text)
            stop = start + 1
    except ValueError:
        raise UserError(f"{option}: expected A:B or A (whole numbers), got {_shown(text)!r}") from None
    if not 0 <= start < stop <= frames:
        raise UserError(f"{option} {_shown(text)}: the clip has frames 0-{frames - 1}")
    return range(start, stop)


def _shown(text: str, most: int = 40) -> str:
    """`text` for a message, cut to `most` characters (a 5,000-digit argument is not echoed whole)."""
    return text if len(text) <= most else f"{text[:most]}... ({len(text):,} characters)"
