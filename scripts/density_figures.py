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
`eval --by-distance` in FOLDER/seed_<n>/<model>/ap/: the compact points (mean and spread over the seeds) on the density
figure, and OUT/compact_ap_by_distance.png (single, late and late - single by distance, one line per density, the mean
over seeds), OUT/compact.md and OUT/compact_by_distance.csv (its tables). Studies are grouped by their training
iterations (table1.csv): one series, table and figure column per budget. Two `--study` at one density and budget are one
study (e.g. early fusion trained in a study of its own): their models together, a model in both taken from the first
given (a line says where the other's differs, e.g. fitted again on another machine). By distance, the mean is over the
seeds with an `ap_by_distance.csv` of both single and late (compact_by_distance.csv's `seeds`); a study with none counts
in the AP tables only.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import statistics
from dataclasses import dataclass
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


@dataclass(frozen=True)
class SeedsStudy:
    """A `simgen-train study --seeds` of the compact models at one density and one training budget."""

    density: float
    iterations: int  # training batches of every model and seed
    folders: tuple[Path, ...]  # one, or those merged by `merge_studies`
    ap: dict[str, dict[str, list[float]]]  # model -> {"3d", "bev"} -> each seed's AP R40 (IoU 0.5, all boxes at t)
    samota: dict[str, list[float]]  # tracker -> sAMOTA (%, IoU 0.25, filtered) of each seed with a table2


def read_study(density: float, folder: Path) -> SeedsStudy:
    """The study's AP and budget from each seed's table1.csv (one budget over its models and seeds, or an error), and
    its trackers' sAMOTA from each seed's table2.csv where there is one."""
    ap: dict[str, dict[str, list[float]]] = {}
    samota: dict[str, list[float]] = {}
    budgets = set()
    for seed in seed_folders(folder):
        with open(seed / "table1.csv") as file:
            for row in csv.DictReader(file):
                budgets.add(int(row["iterations"]))
                if (row["truth_set"], row["box"], row["recall_points"]) == ("all", "t", "40"):
                    ap.setdefault(row["model"], {}).setdefault(row["iou"], []).append(float(row["ap"]))
        if (seed / "table2.csv").is_file():
            with open(seed / "table2.csv") as file:
                for row in csv.DictReader(file):
                    if (row["tracklets"], row["min_iou"]) == ("filtered", "0.25"):
                        samota.setdefault(row["tracker"], []).append(100 * float(row["samota"]))
    if len(budgets) != 1:
        raise SystemExit(f"{folder}: expected one training budget over its models and seeds, found {sorted(budgets)}")
    return SeedsStudy(density, budgets.pop(), (folder,), ap, samota)


def merge_studies(studies: list[SeedsStudy]) -> list[SeedsStudy]:
    """One study per density and budget, in the order first given: the models of all, a model in several taken from
    the first (a line printed where a later one's per-seed AP differs), and so each tracker's sAMOTA."""
    merged: dict[tuple[int, float], SeedsStudy] = {}
    for study in studies:
        key = (study.iterations, study.density)
        if key not in merged:
            merged[key] = study
            continue
        first = merged[key]
        for model, ap in study.ap.items():
            if first.ap.get(model, ap) != ap:
                print(f"x{study.density:g}, {study.iterations} iterations: {model} from {first.folders[0]}; "
                      f"{study.folders[0]}'s differs (3D {first.ap[model]['3d']} against {ap['3d']})")
        merged[key] = SeedsStudy(study.density, study.iterations, first.folders + study.folders,
                                 {**study.ap, **first.ap}, {**study.samota, **first.samota})
    return list(merged.values())


def by_budget(studies: list[SeedsStudy]) -> dict[int, list[SeedsStudy]]:
    """The studies by training budget (iterations), fewest first, each budget's in the order given."""
    groups: dict[int, list[SeedsStudy]] = {}
    for study in sorted(studies, key=lambda st: st.iterations):
        groups.setdefault(study.iterations, []).append(study)
    return groups


def study_bins(study: SeedsStudy) -> dict[str, dict[tuple[float, float], list[dict]]]:
    """single and late -> (low_m, high_m) -> the 3D R40 row of its ap_by_distance.csv of each seed that has one for
    both models, in the first of the study's folders that has ({} where no seed has)."""
    bins: dict[str, dict[tuple[float, float], list[dict]]] = {}
    seeds_read = set()
    for folder in (seed for study_folder in study.folders for seed in seed_folders(study_folder)):
        paths = {model: folder / model / "ap" / "ap_by_distance.csv" for model in ("single", "late")}
        if folder.name in seeds_read or not all(path.is_file() for path in paths.values()):
            continue
        seeds_read.add(folder.name)
        for model, path in paths.items():
            with open(path) as file:
                for row in csv.DictReader(file):
                    if row["iou"] == "3d" and row["recall_points"] == "40":
                        edge = (float(row["low_m"]), float(row["high_m"]))
                        bins.setdefault(model, {}).setdefault(edge, []).append(row)
    return bins


def spread(values: list[float]) -> str:
    """`mean ± sd` over seeds; the value alone for one seed."""
    return "{:.2f} ± {:.2f}".format(*mean_sd(values)) if len(values) > 1 else f"{values[0]:.2f}"


def density_figure(curves: list[tuple[str, float, Path]], studies: list[SeedsStudy], out: Path) -> None:
    """OUT/ap_by_density.png: the paper-size runs (`curves`), the compact studies' AP (one series per model and
    budget) and the paper's Table 1."""
    figure, axes = plt.subplots(figsize=(10, 4.5), dpi=110)
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
        for (budget, group), style in zip(by_budget(studies).items(), itertools.cycle((":^", "-.v", ":D"))):
            small = [(st.density, st.ap[model]["3d"]) for st in group if model in st.ap]
            if small:
                means, sds = zip(*(mean_sd(v) for _, v in small))
                counts = sorted({len(v) for _, v in small})
                seeds = f"{counts[0]}" if len(counts) == 1 else f"{counts[0]} to {counts[-1]}"
                axes.errorbar([d for d, _ in small], means, yerr=sds, fmt=style, color=COLOURS[model], capsize=3,
                              label=f"{model}, ours (compact, CPU, {budget:,} it, mean ± sd of {seeds} seeds)")
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


def compact_distance(studies: list[SeedsStudy], out: Path) -> None:
    """The compact models by distance: single, late and late - single, one line per density (mean over seeds), one
    column per training budget; its table in OUT/compact_by_distance.csv."""
    columns = by_budget(studies)
    densities = sorted({study.density for study in studies})  # one colour per density in every column
    figure, panels = plt.subplots(3, len(columns), figsize=(7 * len(columns), 8), dpi=110, sharex=True,
                                  sharey="row", squeeze=False)
    rows = []
    for column, (budget, group) in enumerate(columns.items()):
        for study in group:
            by_model = study_bins(study)
            if not by_model:
                print(f"{', '.join(map(str, study.folders))}: no seed with an ap_by_distance.csv of single and late; "
                      "left out by distance")
                continue
            edges = sorted(by_model["late"])
            mean = {m: [statistics.mean(float(r["ap"]) for r in by_model[m][e]) for e in edges] for m in by_model}
            centre = [(low + high) / 2 for low, high in edges]
            coarse = [int(by_model["late"][e][0]["truth"]) < MEANINGFUL_TRUTH for e in edges]
            for panel, values in zip(panels[:, column], (mean["single"], mean["late"],
                                                         [a - b for a, b in zip(mean["late"], mean["single"])])):
                line, = panel.plot(centre, values, "-o", label=f"x{study.density:g}", markersize=4,
                                   color=f"C{densities.index(study.density)}")
                hollow = [(c, v) for c, v, few in zip(centre, values, coarse) if few]
                if hollow:  # too few boxes for a fine AP
                    panel.plot(*zip(*hollow), "o", color=line.get_color(), markerfacecolor="white", markersize=4)
            for (low, high), single, late in zip(edges, mean["single"], mean["late"]):
                first = by_model["late"][(low, high)][0]
                rows.append({"iterations": budget, "density": f"{study.density:g}", "low_m": f"{low:g}",
                             "high_m": f"{high:g}", "truth": first["truth"], "median_points": first["median_points"],
                             "seeds": len(by_model["late"][(low, high)]), "single_3d": f"{single:.2f}",
                             "late_3d": f"{late:.2f}", "late_minus_single": f"{late - single:.2f}"})
        panels[0, column].set_title(f"compact, {budget:,} iterations: mean over seeds (hollow: < {MEANINGFUL_TRUTH} "
                                    "boxes)", fontsize=10)
        panels[2, column].axhline(0, color="black", linewidth=0.8)
        panels[2, column].set_xlabel("pitch-plane distance from the sensor (m), bin centre")
    for row, title in enumerate(("single frame", "late fusion", "late - single (the fusion gain)")):
        panels[row, 0].set_ylabel(f"{title}\n3D AP R40 (%)", fontsize=9)
        for panel in panels[row]:
            panel.grid(alpha=0.3)
            panel.legend(fontsize=8, ncols=4)
    figure.tight_layout()
    figure.savefig(out / "compact_ap_by_distance.png")
    plt.close(figure)
    with open(out / "compact_by_distance.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


TRACKERS = ("3D DIoU", "3D DIoU + birth/death + split", "AB3DMOT")  # compact.md's Table 2 columns


def compact_table(studies: list[SeedsStudy], out: Path) -> None:
    """OUT/compact.md: per budget, each density's single and late (and early where run) 3D and BEV AP over seeds, the
    fusion gain, Table 2's sAMOTA over seeds, the x2 -> x1 loss."""
    lines = []
    for budget, group in by_budget(studies).items():
        at = {st.density: st.ap for st in group}
        lines += [f"{budget:,} iterations:", "", "| density | seeds | single 3D | early 3D | late 3D | "
                  "late - single, 3D | single BEV | late BEV | 3D per seed, single / early / late |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
        for density, aps in at.items():
            single, late = aps["single"], aps["late"]
            early = aps.get("early", {"3d": []})["3d"]
            gain = [b - a for a, b in zip(single["3d"], late["3d"])]
            per_seed = " / ".join(" ".join(f"{v:.2f}" for v in values) or "–"
                                  for values in (single["3d"], early, late["3d"]))
            lines.append(f"| x{density:g} | {len(gain)} | {spread(single['3d'])} | {spread(early) if early else '–'} | "
                         f"{spread(late['3d'])} | {spread(gain)} | {spread(single['bev'])} | {spread(late['bev'])} | "
                         f"{per_seed} |")
        lines += ["", "Table 2, sAMOTA (%, IoU 0.25, each tracker at its filter chosen on the train clips), over "
                  "the seeds with a table2.csv:", "", "| density | seeds | " + " | ".join(TRACKERS) + " |",
                  "| --- | ---: |" + " ---: |" * len(TRACKERS)]
        for study in group:
            if study.samota:
                lines.append(f"| x{study.density:g} | {len(study.samota[TRACKERS[0]])} | "
                             + " | ".join(spread(study.samota[tracker]) for tracker in TRACKERS) + " |")
        if 1.0 in at and 2.0 in at:
            lines += ["", "The paper's Δ of 3D (x2 -> x1), ours: the mean at x1 minus the mean at x2 (± the two sds "
                      "added in quadrature); the paper: late -11.83, single -17.91.", ""]
            for model in ("late", "single"):
                x1, x2 = at[1.0][model]["3d"], at[2.0][model]["3d"]
                (mean1, sd1), (mean2, sd2) = mean_sd(x1), mean_sd(x2)
                sd = (f" ± {(sd1 ** 2 + sd2 ** 2) ** 0.5:.2f}" if min(len(x1), len(x2)) > 1
                      else " (one seed at x1 or x2: no spread)")
                lines.append(f"- {model}: {mean1 - mean2:+.2f}{sd}")
        lines.append("")
    (out / "compact.md").write_text("\n".join(lines))


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
    studies = sorted(merge_studies([read_study(float(density), folder) for density, folder in
                                    (split_arg(text, parser) for text in args.study)]),
                     key=lambda st: (st.iterations, st.density))
    args.output.mkdir(parents=True, exist_ok=True)
    density_figure(curves, studies, args.output)
    distance_figure([split_arg(text, parser) for text in args.bins], args.output)
    if studies:
        compact_distance(studies, args.output)
        compact_table(studies, args.output)
    print(f"wrote {args.output / 'ap_by_density.png'} and {args.output / 'ap_by_distance.png'}"
          + (", compact_ap_by_distance.png, compact.md, compact_by_distance.csv" if studies else ""))


if __name__ == "__main__":
    main()
