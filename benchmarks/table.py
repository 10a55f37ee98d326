"""The results file every benchmark writes: a title, the machine and its load, paragraphs and markdown tables."""

from __future__ import annotations

import os
import platform
from collections.abc import Iterable, Sequence
from pathlib import Path

RESULTS_DIR = Path(__file__).resolve().parent / "results"


def machine(**versions: str) -> str:
    """One sentence: Python and the given libraries' versions, the CPU count and the 1-minute load average."""
    named = [f"Python {platform.python_version()}", *(f"{name} {version}" for name, version in versions.items())]
    return (
        f"{', '.join(named)}, {platform.machine()} with {os.cpu_count()} CPUs at load {os.getloadavg()[0]:.1f} "
        "(a shared machine: compare the ratios, not the absolute rates)."
    )


def row(cells: Iterable[object]) -> str:
    """One markdown table row."""
    return "| " + " | ".join(str(cell) for cell in cells) + " |"


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[object]], left: int = 1) -> str:
    """A markdown table: the first `left` columns aligned left, the others (numbers) right."""
    rule = ["---"] * left + ["---:"] * (len(header) - left)
    return "\n".join([row(header), row(rule), *(row(cells) for cells in rows)])


def write_results(name: str, title: str, *blocks: str, out: Path | None = None) -> Path:
    """Write `# title` and the blocks (paragraphs, tables) to results/<name>.md, or to `out`; print it."""
    path = out or RESULTS_DIR / f"{name}.md"
    text = "\n\n".join([f"# {title}", *blocks]) + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    print(text + f"\nwrote {path}", flush=True)
    return path
