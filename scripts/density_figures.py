"""The density sweep's two figures (docs/density_sweep.md): 3D AP against density, ours beside the paper's Table 1,
and 3D AP against distance from the sensor with the median points per player.

    .venv/bin/python scripts/density_figures.py -o studies/density_sweep \\
        --curve "late@1=studies/paper_x1_snapshot_track_sizes_gpu/late/learning_curve.csv" \\
        --bins "late x1=studies/density_sweep/late_x1/ap_by_distance.csv" ...

`--curve MODEL@DENSITY=PATH`: a `learning_curve.csv` of `simgen-train fit`, its last row's 3d_r40 the point (several
at one density, e.g. seeds: their mean and sd).
`--bins LABEL=PATH`: an `ap_by_distance.csv` of `simgen-train score|eval --by-distance`. Writes OUT/ap_by_density.png
and OUT/ap_by_distance.png.

`--study DENSITY=FOLDER`: a `simgen-train study --seeds` of single and late (FOLDER/seed_<n>/table1.csv), each model's
`eval --by-distance` in FOLDER/seed_<n>/<model>/ap/: the compact points (mean and spread over the seeds) on the
density figure, and OUT/compact_ap_by_distance.png (single, late and late - single by distance, one line per
density, the mean over seeds), OUT/compact.md and OUT/compact_by_distance.csv (its tables).
"""

from __future__ import annotations

import argparse
import csv
import statistics
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from train.evaluation.ap_table import MEANINGFUL_TRUTH
from train.study.seeds import mean_sd

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


def seed_folders(study: Path) -> list[Path]:
    """A seeds study's seed_<n>/ folders, by seed."""
    return sorted(study.glob("seed_*"), key=lambda folder: int(folder.name.removeprefix("seed_")))


def study_ap(study: Path) -> dict[str, dict[str, list[float]]]:
    """model -> {"3d", "bev"} -> each seed's AP R40 (IoU 0.5, all val boxes at t) of a seeds study."""
    result: dict[str, dict[str, list[float]]] = {}
    for folder in seed_folders(study):
        with open(folder / "table1.csv") as file:
            for row in csv.DictReader(file):
                if (row["truth_set"], row["box"], row["recall_points"]) == ("all", "t", "40"):
                    result.setdefault(row["model"], {}).setdefault(row["iou"], []).append(float(row["ap"]))
    return result


def study_bins(study: Path, model: str) -> dict[tuple[float, float], list[dict]]:
    """(low_m, high_m) -> each seed's 3D R40 row of the model's ap_by_distance.csv."""
    bins: dict[tuple[float, float], list[dict]] = {}
    for folder in seed_folders(study):
        with open(folder / model / "ap" / "ap_by_distance.csv") as file:
            for row in csv.DictReader(file):
                if row["iou"] == "3d" and row["recall_points"] == "40":
                    bins.setdefault((float(row["low_m"]), float(row["high_m"])), []).append(row)
    return bins


def spread(values: list[float]) -> str:
    return "{:.2f} ± {:.2f}".format(*mean_sd(values))


def density_figure(curves: list[tuple[str, float, Path]], compact: dict[float, dict[str, dict[str, list[float]]]],
                   out: Path) -> None:
    """OUT/ap_by_density.png: the paper-size runs (`curves`), the compact studies' AP (`compact`: density -> study_ap)
    and the paper's Table 1."""
    figure, axes = plt.subplots(figsize=(10, 4.5), dpi=110)
    seeds = max((len(v["3d"]) for aps in compact.values() for v in aps.values()), default=0)
    for model in COLOURS:
        runs: dict[float, list[float]] = {}
        for m, d, p in curves:
            if m == model:
                runs.setdefault(d, []).append(last_3d_ap(p))
        if runs:
            densities = sorted(runs)
            means, sds = zip(*(mean_sd(runs[d]) for d in densities))
            axes.errorbar(densities, means, yerr=sds, fmt="-o", color=COLOURS[model], capsize=3,
                          label=f"{model}, ours (paper size, H100; mean ± sd where several seeds)")
        paper = sorted((d, ap) for (m, d), ap in PAPER_3D_AP.items() if m == model)
        if paper:
            axes.plot(*zip(*paper), "--s", color=COLOURS[model], label=f"{model}, the paper")
        small = sorted((d, aps[model]["3d"]) for d, aps in compact.items() if model in aps)
        if small:
            means, sds = zip(*(mean_sd(v) for _, v in small))
            axes.errorbar([d for d, _ in small], means, yerr=sds, fmt=":^", color=COLOURS[model], capsize=3,
                          label=f"{model}, ours (compact, CPU, mean ± sd of {seeds} seeds)")
    axes.set_xscale("log", base=2)
    axes.set_xticks([0.25, 0.5, 1, 2], ["x0.25", "x0.5", "x1", "x2"])
    axes.set_xlim(0.2, 2.5)
    axes.set_xlabel("scan density")
    axes.set_ylabel("val 3D AP R40 (%), IoU 0.5")
    axes.set_title("3D AP against density: paper-like data vs the paper's Table 1")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1))
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


def compact_distance(studies: list[tuple[float, Path]], out: Path) -> None:
    """The compact models by distance: single, late and late - single, one line per density (mean over seeds); its
    table in OUT/compact_by_distance.csv."""
    figure, panels = plt.subplots(3, 1, figsize=(7, 8), dpi=110, sharex=True)
    rows = []
    for density, folder in sorted(studies):
        by_model = {model: study_bins(folder, model) for model in ("single", "late")}
        edges = sorted(by_model["late"])
        mean = {m: [statistics.mean(float(r["ap"]) for r in by_model[m][e]) for e in edges] for m in by_model}
        centre = [(low + high) / 2 for low, high in edges]
        label = f"x{density:g}"
        coarse = [int(by_model["late"][e][0]["truth"]) < MEANINGFUL_TRUTH for e in edges]
        for panel, values in zip(panels, (mean["single"], mean["late"],
                                          [a - b for a, b in zip(mean["late"], mean["single"])])):
            line, = panel.plot(centre, values, "-o", label=label, markersize=4)
            hollow = [(c, v) for c, v, few in zip(centre, values, coarse) if few]
            if hollow:  # too few boxes for a fine AP
                panel.plot(*zip(*hollow), "o", color=line.get_color(), markerfacecolor="white", markersize=4)
        for (low, high), single, late in zip(edges, mean["single"], mean["late"]):
            first = by_model["late"][(low, high)][0]
            rows.append({"density": f"{density:g}", "low_m": f"{low:g}", "high_m": f"{high:g}", "truth": first["truth"],
                         "median_points": first["median_points"], "single_3d": f"{single:.2f}",
                         "late_3d": f"{late:.2f}", "late_minus_single": f"{late - single:.2f}"})
    for panel, title in zip(panels, ("single frame", "late fusion", "late - single (the fusion gain)")):
        panel.set_ylabel(f"{title}\n3D AP R40 (%)", fontsize=9)
        panel.grid(alpha=0.3)
        panel.legend(fontsize=8, ncols=4)
    panels[2].axhline(0, color="black", linewidth=0.8)
    panels[0].set_title(f"compact models by distance from the sensor, mean over seeds (hollow: < {MEANINGFUL_TRUTH} "
                        "boxes)", fontsize=10)
    panels[2].set_xlabel("pitch-plane distance from the sensor (m), bin centre")
    figure.tight_layout()
    figure.savefig(out / "compact_ap_by_distance.png")
    plt.close(figure)
    with open(out / "compact_by_distance.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def compact_table(compact: dict[float, dict[str, dict[str, list[float]]]], out: Path) -> None:
    """OUT/compact.md: each density's single and late 3D and BEV AP over seeds, the fusion gain, the x2 -> x1 loss."""
    lines = ["| density | single 3D | late 3D | late - single, 3D | single BEV | late BEV | 3D per seed, single / "
             "late |", "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for density, aps in compact.items():
        single, late = aps["single"], aps["late"]
        gain = [b - a for a, b in zip(single["3d"], late["3d"])]
        lines.append(f"| x{density:g} | {spread(single['3d'])} | {spread(late['3d'])} | {spread(gain)} | "
                     f"{spread(single['bev'])} | {spread(late['bev'])} | "
                     f"{' '.join(f'{v:.2f}' for v in single['3d'])} / {' '.join(f'{v:.2f}' for v in late['3d'])} |")
    if 1.0 in compact and 2.0 in compact:
        lines += ["", "The paper's Δ of 3D (x2 -> x1), ours: the mean at x1 minus the mean at x2 (± the two sds added "
                  "in quadrature); the paper: late -11.83, single -17.91.", ""]
        for model in ("late", "single"):
            x1, x2 = compact[1.0][model]["3d"], compact[2.0][model]["3d"]
            (mean1, sd1), (mean2, sd2) = mean_sd(x1), mean_sd(x2)
            sd = (sd1 ** 2 + sd2 ** 2) ** 0.5 if min(len(x1), len(x2)) > 1 else 0.0
            lines.append(f"- {model}: {mean1 - mean2:+.2f} ± {sd:.2f}")
    (out / "compact.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, required=True, help="folder for the two PNGs")
    parser.add_argument("--curve", action="append", default=[], help="MODEL@DENSITY=PATH of a learning_curve.csv")
    parser.add_argument("--bins", action="append", default=[], help="LABEL=PATH of an ap_by_distance.csv")
    parser.add_argument("--study", action="append", default=[], help="DENSITY=FOLDER of a seeds study")
    args = parser.parse_args()
    curves = []
    for text in args.curve:
        label, path = split_arg(text, parser)
        model, _, density = label.partition("@")
        if model not in COLOURS or not density:
            parser.error(f"{text!r}: expected MODEL@DENSITY=PATH, MODEL one of {', '.join(COLOURS)}")
        curves.append((model, float(density), path))
    studies = [(float(density), folder) for density, folder in (split_arg(text, parser) for text in args.study)]
    compact = {density: study_ap(folder) for density, folder in sorted(studies)}
    args.output.mkdir(parents=True, exist_ok=True)
    density_figure(curves, compact, args.output)
    distance_figure([split_arg(text, parser) for text in args.bins], args.output)
    if studies:
        compact_distance(studies, args.output)
        compact_table(compact, args.output)
    print(f"wrote {args.output / 'ap_by_density.png'} and {args.output / 'ap_by_distance.png'}"
          + (", compact_ap_by_distance.png, compact.md, compact_by_distance.csv" if studies else ""))


if __name__ == "__main__":
    main()
