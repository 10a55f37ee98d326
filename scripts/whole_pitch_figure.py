"""The whole-pitch study's figure (docs/whole_pitch_study.md): 3D AP and sAMOTA in each pitch zone, rig beside rig.

    .venv/bin/python scripts/whole_pitch_figure.py -o studies/whole_pitch/zones.png \\
        --ap "goals, late=studies/whole_pitch/whole_mid100_goals_snapshot_track_sizes/late_ap/ap_by_zone.csv" ... \\
        --tracking "goals=studies/whole_pitch/whole_mid100_goals_snapshot_track_sizes/zones/table2_by_zone.csv" ...

`--ap LABEL=PATH`: an `ap_by_zone.csv` of `simgen-train eval|score --by-zone` (3D AP R40). `--tracking LABEL=PATH`: a
`table2_by_zone.csv` of `simgen-train table2 --by-zone` (sAMOTA of the paper's full tracker at 3D IoU 0.25).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from train.evaluation.zones import ZONES
from train.study.run import TRACKER_CONFIGS
from train.track.run import DEFAULT_TRACKER
from train.tracking.config import load_tracker_config


def labelled(texts: list[str], parser: argparse.ArgumentParser) -> list[tuple[str, Path]]:
    """LABEL=PATH arguments as (label, path)."""
    pairs = [(label, Path(path)) for label, _, path in (text.partition("=") for text in texts)]
    if any(not str(path) or str(path) == "." for _, path in pairs):
        parser.error("expected LABEL=PATH")
    return pairs


def zone_values(path: Path, keep, value) -> list[float]:
    """Per zone of ZONES, `value` of the CSV's row that `keep` picks (NaN where the zone has none)."""
    with open(path) as file:
        rows = {r["zone"]: r for r in csv.DictReader(file) if keep(r)}
    return [value(rows[z]) if z in rows else float("nan") for z in ZONES]


def bars(axes, series: list[tuple[str, list[float]]], ylabel: str) -> None:
    width = 0.8 / max(1, len(series))
    for i, (label, values) in enumerate(series):
        positions = [z + (i - (len(series) - 1) / 2) * width for z in range(len(ZONES))]
        drawn = axes.bar(positions, values, width, label=label)
        axes.bar_label(drawn, fmt="%.1f", fontsize=7)
    axes.set_xticks(range(len(ZONES)), [f"{z}" for z in ZONES])
    axes.set_ylabel(ylabel)
    axes.set_ylim(0, 100)
    axes.grid(axis="y", alpha=0.3)
    axes.legend(fontsize=7, loc="upper right")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--ap", action="append", default=[], help="LABEL=PATH of an ap_by_zone.csv")
    parser.add_argument("--tracking", action="append", default=[], help="LABEL=PATH of a table2_by_zone.csv")
    args = parser.parse_args()
    ap = [(label, zone_values(path, lambda r: (r["iou"], r["recall_points"]) == ("3d", "40"), lambda r: float(r["ap"])))
          for label, path in labelled(args.ap, parser)]
    full = load_tracker_config(TRACKER_CONFIGS / DEFAULT_TRACKER).name  # the paper's full tracker
    tracking = [(label, zone_values(path, lambda r: (r["tracker"], r["tracklets"], float(r["min_iou"])) ==
                                    (full, "filtered", 0.25), lambda r: 100 * float(r["samota"])))
                for label, path in labelled(args.tracking, parser)]
    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5), dpi=110)
    bars(left, ap, "val 3D AP R40 (%), IoU 0.5")
    left.set_title("detection by pitch zone")
    bars(right, tracking, "val sAMOTA (%), 3D IoU 0.25")
    right.set_title("the paper's full tracker by pitch zone")
    figure.tight_layout()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.output)
    plt.close(figure)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
