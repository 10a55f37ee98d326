"""The learning curve: AP of the boxes at t on the val clips against training iterations, as CSV and PNG.

`fit` scores the model every `train.eval_every` iterations and after the last one; the plot also
draws the training loss from the fit's log, so a reader sees whether more iterations would help.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from simgen.atomic import atomic_path
from train.evaluation.ap_table import ApRow, mean_ap

CSV_NAME = "learning_curve.csv"
PNG_NAME = "learning_curve.png"
FIELDS = ("iteration", "bev_r40", "3d_r40", "bev_r11", "3d_r11", "truth", "detections", "eval_s")


@dataclass(frozen=True)
class CurvePoint:
    iteration: int
    rows: list[ApRow]  # AP rows of one val pass (train.evaluation.ap_table.average_precisions)
    eval_s: float


def curve_csv(points: list[CurvePoint]) -> str:
    """One line per evaluation: AP (percent) of the box at t, BEV and 3D, R40 and R11."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(FIELDS)
    for p in points:
        t = next(r for r in p.rows if r.box == "t")
        aps = [mean_ap(p.rows, iou, n) for n in (40, 11) for iou in ("bev", "3d")]
        writer.writerow([p.iteration, *(f"{a:.2f}" for a in aps), t.truth, t.detections, f"{p.eval_s:.1f}"])
    return text.getvalue()


def plot_curve(points: list[CurvePoint], losses: list[tuple[int, float]], title: str, path: Path) -> None:
    """AP (R40) against iterations above, the training loss (iteration, loss) below."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, gridspec_kw={"height_ratios": [2, 1]},
                                      layout="constrained")
    iterations = [p.iteration for p in points]
    for iou, label in (("bev", "BEV"), ("3d", "3D")):
        top.plot(iterations, [mean_ap(p.rows, iou) for p in points], marker="o", label=f"{label} AP (R40), box at t")
    top.set_ylabel("AP on val, %")
    top.set_title(title)
    top.grid(True, alpha=0.3)
    top.legend(fontsize=8)
    bottom.plot([i for i, _ in losses], [v for _, v in losses], linewidth=0.8)
    bottom.set_yscale("log")
    bottom.set_xlabel("training iterations (batches)")
    bottom.set_ylabel("training loss")
    bottom.grid(True, which="both", alpha=0.3)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def read_curve(out: Path, until: int) -> list[CurvePoint]:
    """The points of OUT/learning_curve.csv up to iteration `until` (a fit resumed there), as far as the CSV
    keeps them: the AP of the box at t, all labelled boxes."""
    path = out / CSV_NAME
    if not path.is_file():
        return []
    points = []
    with open(path, newline="") as file:
        for row in csv.DictReader(file):
            if int(row["iteration"]) > until:
                break
            count = {"truth": int(row["truth"]), "detections": int(row["detections"])}
            rows = [ApRow("t", iou, n, float(row[f"{iou}_r{n}"]), **count) for n in (40, 11) for iou in ("bev", "3d")]
            points.append(CurvePoint(int(row["iteration"]), rows, float(row["eval_s"])))
    return points


def write_curve(out: Path, points: list[CurvePoint], losses: list[tuple[int, float]], title: str) -> list[Path]:
    """OUT/learning_curve.csv and .png, written atomically."""
    with atomic_path(out / CSV_NAME) as tmp:
        tmp.write_text(curve_csv(points))
    plot_curve(points, losses, title, out / PNG_NAME)
    return [out / CSV_NAME, out / PNG_NAME]
