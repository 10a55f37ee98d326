"""The density sweep's two figures (docs/density_sweep.md): 3D AP against density, ours beside the paper's Table 1,
and 3D AP against distance from the sensor with the median points per player.

    .venv/bin/python scripts/density_figures.py -o studies/density_sweep \\
        --curve "late@1=studies/paper_x1_snapshot_track_sizes_gpu/late/learning_curve.csv" \\
        --bins "late x1=studies/density_sweep/late_x1/ap_by_distance.csv" ...

`--curve MODEL@DENSITY=PATH`: a `learning_curve.csv` of `simgen-train fit`, its last row's 3d_r40 the point.
`--bins LABEL=PATH`: an `ap_by_distance.csv` of `simgen-train score|eval --by-distance`. Writes OUT/ap_by_density.png
and OUT/ap_by_distance.png.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from train.evaluation.ap_table import MEANINGFUL_TRUTH

# The paper's Table 1, 3D AP (IoU 0.5) on its simulated data: (model, density) -> AP.
PAPER_3D_AP = {("single", 2.0): 51.65, ("late", 2.0): 83.30, ("single", 1.0): 33.74, ("late", 1.0): 71.47,
               ("early", 1.0): 56.61}
COLOURS = {"late": "tab:blue", "early": "tab:green", "single": "tab:orange"}


def last_3d_ap(path: Path) -> float:
    """The last row's 3d_r40 of a learning_curve.csv."""
    with open(path) as file:
        return float(list(csv.DictReader(file))[-1]["3d_r40"])


def split_arg(text: str, parser: argparse.ArgumentParser) -> tuple[str, Path]:
    label, _, path = text.partition("=")
    if not path:
        parser.error(f"{text!r}: expected LABEL=PATH")
    return label, Path(path)


def density_figure(curves: list[tuple[str, float, Path]], out: Path) -> None:
    figure, axes = plt.subplots(figsize=(6.5, 4.5), dpi=110)
    for model in COLOURS:
        ours = sorted((d, last_3d_ap(p)) for m, d, p in curves if m == model)
        paper = sorted((d, ap) for (m, d), ap in PAPER_3D_AP.items() if m == model)
        for points, style, who in ((ours, "-o", "ours (paper size, H100, one seed)"), (paper, "--s", "the paper")):
            if points:
                axes.plot(*zip(*points), style, color=COLOURS[model], label=f"{model}, {who}")
    axes.set_xscale("log", base=2)
    axes.set_xticks([0.25, 0.5, 1, 2], ["x0.25", "x0.5", "x1", "x2"])
    axes.set_xlim(0.2, 2.5)
    axes.set_xlabel("scan density (x0.25 and x0.5 not run yet)")
    axes.set_ylabel("val 3D AP R40 (%), IoU 0.5")
    axes.set_title("3D AP against density: paper-like data vs the paper's Table 1")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(out / "ap_by_density.png")
    plt.close(figure)


def distance_figure(bins: list[tuple[str, Path]], out: Path) -> None:
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), dpi=110, sharex=True, height_ratios=(2, 1))
    for label, path in bins:
        with open(path) as file:
            rows = [r for r in csv.DictReader(file) if r["iou"] == "3d" and r["recall_points"] == "40"]
        centre = [(float(r["low_m"]) + float(r["high_m"])) / 2 for r in rows]
        line, = top.plot(centre, [float(r["ap"]) for r in rows], "-o", label=label)
        coarse = [(c, float(r["ap"])) for c, r in zip(centre, rows) if int(r["truth"]) < MEANINGFUL_TRUTH]
        if coarse:  # hollow: too few boxes for a fine AP
            top.plot(*zip(*coarse), "o", color=line.get_color(), markerfacecolor="white")
        bottom.plot(centre, [float(r["median_points"]) for r in rows], "-o", label=label)
    top.set_ylabel("3D AP R40 (%), IoU 0.5")
    top.set_title(f"late fusion (paper size) by distance from the sensor (hollow: < {MEANINGFUL_TRUTH} boxes)")
    bottom.set_ylabel("median points per\nplayer at t")
    bottom.set_xlabel("pitch-plane distance from the sensor (m), bin centre")
    for axes in (top, bottom):
        axes.grid(alpha=0.3)
        axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(out / "ap_by_distance.png")
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, required=True, help="folder for the two PNGs")
    parser.add_argument("--curve", action="append", default=[], help="MODEL@DENSITY=PATH of a learning_curve.csv")
    parser.add_argument("--bins", action="append", default=[], help="LABEL=PATH of an ap_by_distance.csv")
    args = parser.parse_args()
    curves = []
    for text in args.curve:
        label, path = split_arg(text, parser)
        model, _, density = label.partition("@")
        if model not in COLOURS or not density:
            parser.error(f"{text!r}: expected MODEL@DENSITY=PATH, MODEL one of {', '.join(COLOURS)}")
        curves.append((model, float(density), path))
    args.output.mkdir(parents=True, exist_ok=True)
    density_figure(curves, args.output)
    distance_figure([split_arg(text, parser) for text in args.bins], args.output)
    print(f"wrote {args.output / 'ap_by_density.png'} and {args.output / 'ap_by_distance.png'}")


if __name__ == "__main__":
    main()
