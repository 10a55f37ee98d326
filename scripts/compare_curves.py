"""Learning curves of several runs in one picture: val 3D AP R40 (percent) against training iterations.

    .venv/bin/python scripts/compare_curves.py -o docs/study_paper_gap.png \
        "late, swept=studies/paper_x1_restarts/late_learning_curve.csv" \
        "late, snapshot=studies/paper_x1_snapshot/late_learning_curve.csv"

Each argument is LABEL=PATH of a `learning_curve.csv` that `simgen-train fit` wrote (columns
iteration, bev_r40, 3d_r40, ...). Runs whose label starts with the same word share a line style.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def read(path: Path, column: str) -> tuple[list[int], list[float]]:
    """(iterations, values of `column`) of one learning_curve.csv."""
    with open(path) as file:
        rows = list(csv.DictReader(file))
    return [int(r["iteration"]) for r in rows], [float(r[column]) for r in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="LABEL=PATH of a learning_curve.csv")
    parser.add_argument("-o", "--output", type=Path, required=True, help="PNG to write")
    parser.add_argument("--column", default="3d_r40", help="curve column (default 3d_r40)")
    parser.add_argument("--title", default="val 3D AP R40 (%), IoU 0.5, all boxes")
    args = parser.parse_args()
    styles = {}
    figure, axes = plt.subplots(figsize=(7, 4.5), dpi=110)
    for run in args.runs:
        label, _, path = run.partition("=")
        if not path:
            parser.error(f"{run!r}: expected LABEL=PATH")
        group = label.split(",")[0]
        style = styles.setdefault(group, ("-", "--", ":", "-.")[len(styles) % 4])
        iterations, values = read(Path(path), args.column)
        axes.plot(iterations, values, style, marker="o", markersize=3, label=label)
    axes.set_xlabel("training iterations (batch 2)")
    axes.set_ylabel(args.column)
    axes.set_title(args.title)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
