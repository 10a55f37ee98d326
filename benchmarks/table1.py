"""The paper's Table 1 on simgen data: single x2, late x2, single x1, early x1, late x1.

Each row trains one config (train/configs/) for the same number of iterations on the dataset's
`train` clips, from the same seed, then evaluates the boxes at t on its `val` clips (KITTI-style
AP at IoU 0.5, 40 recall points; 11 as well). Writes benchmarks/results/table1.md and .csv.

    .venv/bin/python benchmarks/table1.py --iterations 500 --workers 1 --out out/table1
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from train.checkpoint import load_checkpoint
from train.config import load_config
from train.detector.model import Detector
from train.evaluation.ap_table import evaluate, mean_ap
from train.fit import fit

ROWS = (("single", "x2"), ("late", "x2"), ("single", "x1"), ("early", "x1"), ("late", "x1"))
LABELS = {"single": "Single Frame", "early": "Early Fusion", "late": "Late Fusion"}
PAPER = {("single", "x2"): (56.46, 51.65), ("late", "x2"): (86.26, 83.30), ("single", "x1"): (44.51, 33.74),
         ("early", "x1"): (69.03, 56.61), ("late", "x1"): (75.21, 71.47)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--iterations", type=int, required=True, help="training iterations per model (batch from the config)"
    )
    parser.add_argument("--workers", type=int, default=1, help="loader processes")
    parser.add_argument("--datasets", default="datasets", help="folder holding paper_x1/ and paper_x2/")
    parser.add_argument("--out", default="out/table1", help="runs (checkpoints, logs)")
    parser.add_argument("--results", default=str(ROOT / "benchmarks" / "results"), help="where table1.md/.csv go")
    parser.add_argument("--rows", default=",".join(f"{m}_{d}" for m, d in ROWS), help="rows to run, in this order")
    args = parser.parse_args()
    order = [tuple(row.split("_")) for row in args.rows.split(",")]
    if not set(order) <= set(ROWS):
        parser.error(f"--rows: each of {', '.join(f'{m}_{d}' for m, d in ROWS)}")
    device = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    out, results = Path(args.out), Path(args.results)
    rows = []
    for model, density in order:
        config = load_config(ROOT / "train" / "configs" / f"{model}.yaml")
        config = config.model_copy(
            update={"train": config.train.model_copy(update={"iterations": args.iterations, "workers": args.workers})}
        )
        dataset = str(Path(args.datasets) / f"paper_{density}")
        run = out / f"{model}_{density}"
        start = time.perf_counter()
        trained = fit(config, dataset, run, device, progress=False, overwrite=True)
        fit_s = time.perf_counter() - start
        checkpoint = load_checkpoint(trained.checkpoint)
        detector = Detector(checkpoint.config)
        detector.load_state_dict(checkpoint.model)
        result = evaluate(detector, checkpoint.config, dataset, "val", device, progress=False)
        ap = {(iou, n): mean_ap(result.rows, iou, n) for iou in ("bev", "3d") for n in (40, 11)}
        rows.append((model, density, ap, result.rows[0].truth, fit_s, trained.samples_per_s, result.frames_per_s))
        print(f"{model} {density}: BEV {ap['bev', 40]:.2f} 3D {ap['3d', 40]:.2f} (R40), fit {fit_s:.0f} s", flush=True)
        write(rows, args, results, device)
    return 0


def write(rows: list, args: argparse.Namespace, results: Path, device: torch.device) -> None:
    results.mkdir(parents=True, exist_ok=True)
    rows = sorted(rows, key=lambda row: ROWS.index(row[:2]))  # the paper's order
    with open(results / "table1.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "model",
                "density",
                "bev_r40",
                "3d_r40",
                "bev_r11",
                "3d_r11",
                "val_truth",
                "fit_s",
                "train_samples_per_s",
                "eval_frames_per_s",
            ]
        )
        for model, density, ap, truth, fit_s, sps, fps in rows:
            w.writerow(
                [
                    model,
                    density,
                    *(f"{ap[k]:.2f}" for k in (("bev", 40), ("3d", 40), ("bev", 11), ("3d", 11))),
                    truth,
                    f"{fit_s:.0f}",
                    f"{sps:.3f}",
                    f"{fps:.3f}",
                ]
            )
    single_x2 = next((r[2]["3d", 40] for r in rows if r[:2] == ("single", "x2")), None)
    late_x2 = next((r[2]["3d", 40] for r in rows if r[:2] == ("late", "x2")), None)
    lines = [
        "# Table 1 on simgen data (boxes at t, val clips, IoU 0.5)",
        "",
        f"Command: `.venv/bin/python benchmarks/table1.py --iterations {args.iterations} --workers {args.workers}"
        f" --rows {args.rows}`",
        f"(each model: {args.iterations} iterations from seed 0, batch size from its config, on {device.type}).",
        "AP in percent, KITTI 40 recall points (11 in brackets). Δ of 3D: x1 minus x2 of the same method.",
        "",
        "| Method | BEV | 3D | Δ of 3D | paper BEV | paper 3D | train samples/s |",
        "|---|---|---|---|---|---|---|",
    ]
    for model, density, ap, _truth, _fit_s, sps, _fps in rows:
        ref = {"single": single_x2, "late": late_x2}.get(model) if density == "x1" else None
        delta = f"{ap['3d', 40] - ref:+.2f}" if ref is not None else "–"
        paper = PAPER[model, density]
        lines.append(
            f"| {LABELS[model]} (×{density[1]}) | {ap['bev', 40]:.2f} ({ap['bev', 11]:.2f}) | {ap['3d', 40]:.2f} "
            f"({ap['3d', 11]:.2f}) "
            f"| {delta} | {paper[0]:.2f} | {paper[1]:.2f} | {sps:.2f} |"
        )
    lines += ["", f"Ground-truth boxes at t in the val clip: {rows[-1][3]}."]
    (results / "table1.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
