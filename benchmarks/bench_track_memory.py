"""Whole-match tracking memory: the peak RSS of `simgen-train track` over a long clip against a short one.

One clip of a cheap scenario (smoke's 11 vs 11 match at 10 Hz, the sensors at 5 % of their shots: the points do
not matter here) is generated at `--short` and at `--long` frames; KITTI detections are written from its labels
(tests.support.kitti_detections: 5 cm of noise, a tenth of the boxes missing, random scores); then
`simgen-train track --detections` (the paper's full tracker, every output: KITTI results, the tracks table, an
MCAP of points and tracks, the metrics) runs on each in a child process (benchmarks/measure_child.py: its own
peak RSS, free of this process's). Reported: frames, peak RSS, CPU time, the ratio of the peak RSS of the long
run to the short one's (flat memory: near 1), and each run's IDS and FRAG per 10 minutes of play.

Generating the long clip takes a few minutes; `--work DIR` keeps the datasets and detections for a rerun.

Usage: .venv/bin/python benchmarks/bench_track_memory.py [--short 600] [--long 6000] [--work DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml
from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support.kitti_detections import write_detections

DENSITY = 0.05


def dataset(work: Path, frames: int) -> tuple[Path, Path]:
    """A one-clip dataset of `frames` frames and its KITTI detections (made once in `work`)."""
    folder, detections = work / f"smoke_{frames}", work / f"detections_{frames}"
    if not detections.exists():
        scenario = yaml.safe_load((ROOT / "scenarios" / "smoke.yaml").read_text())
        scenario["motion"]["frames"] = frames
        (work / f"smoke_{frames}.yaml").write_text(yaml.safe_dump(scenario))
        subprocess.run([sys.executable, "-m", "simgen.cli", "generate", str(work / f"smoke_{frames}.yaml"), "-o",
                        str(folder), "--frames", str(frames), "--clips", "1", "--density", str(DENSITY),
                        "--overwrite"], check=True, capture_output=True, cwd=ROOT)
        write_detections(folder, detections, np.random.default_rng(0))
    return folder, detections


def track(work: Path, frames: int) -> dict:
    """`track` of the `frames`-frame clip in a measured child: its report and printed lines."""
    folder, detections = dataset(work, frames)
    report = work / f"report_{frames}.json"
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "measure_child.py"), str(report),
                           sys.executable, "-m", "train.cli", "track", "--dataset", str(folder), "--detections",
                           str(detections), "-o", str(work / f"out_{frames}"), "--split", "all", "--quiet"],
                          check=True, capture_output=True, text=True, cwd=ROOT)
    result = json.loads(report.read_text())
    result["per_10_min"] = done.stdout.strip().splitlines()[-1].split("per 10 minutes of play ")[-1]
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short", type=int, default=600, help="frames of the short clip")
    parser.add_argument("--long", type=int, default=6000, help="frames of the long clip")
    parser.add_argument("--work", type=Path, default=None, help="keep datasets and outputs here (default: temporary)")
    parser.add_argument("--out", type=Path, default=None, help="results file (default: track_memory.md)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as temporary:
        work = args.work or Path(temporary)
        work.mkdir(parents=True, exist_ok=True)
        runs = {frames: track(work, frames) for frames in (args.short, args.long)}
    rows = [[f"{frames:,}", f"{frames / 600:.0f} min" if frames >= 600 else f"{frames / 10:.0f} s",
             f"{r['peak_bytes'] / 2**20:.0f}", f"{r['cpu_s']:.1f}", r["per_10_min"]] for frames, r in runs.items()]
    ratio = runs[args.long]["peak_bytes"] / runs[args.short]["peak_bytes"]
    print(f"peak RSS ratio {args.long} / {args.short} frames: {ratio:.3f}", flush=True)
    write_results(
        "track_memory", "Whole-match tracking memory",
        f"Written by `benchmarks/bench_track_memory.py`: `simgen-train track --detections` (the paper's full tracker, "
        f"every output) over one clip of smoke's 11 vs 11 match at 10 Hz (sensors at {DENSITY:g} of their shots), "
        f"KITTI detections written from its labels (5 cm noise, a tenth missing, random scores), each run in a "
        f"child process measured alone (benchmarks/measure_child.py). {machine(numpy=np.__version__)}",
        markdown_table(["frames", "play", "peak RSS (MiB)", "CPU s", "per 10 minutes of play"], rows),
        f"Peak RSS of {args.long:,} frames over {args.short:,}: {ratio:.3f}.",
        out=args.out,
    )


if __name__ == "__main__":
    main()
