"""End-to-end generation benchmark: `simgen generate` on the paper's x1 scenario, 1 and 2 workers,
and bytes per frame per format.

Frames per second count everything (engine capture, rendering, labels, writing, manifest); the
baseline is the same command with 1 worker, measured in the same run. Bytes per frame are compared
with the raw float32 (x, y, z, intensity) arrays of the same frames. Writes
benchmarks/results/generate.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "paper_x1.yaml"


def _generate(out: Path, *extra: str) -> float:
    command = [sys.executable, "-m", "simgen.cli", "generate", str(SCENARIO), "-o", str(out), *extra]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True)
    return time.perf_counter() - started


def _totals(out: Path) -> tuple[int, int, int]:
    manifest = json.loads((out / "manifest.json").read_text())
    frames = sum(c["frames"] for c in manifest["clips"])
    points = sum(c["points"] for c in manifest["clips"])
    return frames, points, sum(f["bytes"] for f in manifest["files"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=4, help="clips (paper_x1 has 4)")
    parser.add_argument("--frames", type=int, default=205, help="frames per clip (paper_x1 has 205)")
    args = parser.parse_args()
    common = ["--clips", str(args.clips), "--frames", str(args.frames)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        one_s = _generate(tmp / "one", *common)
        two_s = _generate(tmp / "two", *common, "--workers", "2")
        frames, points, parquet_bytes = _totals(tmp / "one")
        rows = [
            ["1 worker (baseline)", frames, f"{one_s:.1f}", f"{frames / one_s:.1f}", "1.00"],
            ["2 workers", frames, f"{two_s:.1f}", f"{frames / two_s:.1f}", f"{one_s / two_s:.2f}"],
        ]
        raw = points * 16 / frames  # float32 x, y, z, intensity
        sizes = [["raw float32 x, y, z, intensity (baseline)", f"{raw:,.0f}", "1.00"]]
        sizes.append(["parquet (all fields)", f"{parquet_bytes / frames:,.0f}", f"{parquet_bytes / frames / raw:.2f}"])
        for fmt in ("kitti", "kitti_tracking", "openpcdet"):
            _generate(tmp / fmt, "--clips", "1", "--frames", str(args.frames), "--format", fmt)
            f_frames, f_points, f_bytes = _totals(tmp / fmt)
            sizes.append([fmt, f"{f_bytes / f_frames:,.0f}", f"{f_bytes / f_frames / (f_points * 16 / f_frames):.2f}"])
    write_results(
        "generate",
        "Generation benchmark",
        f"`simgen generate scenarios/paper_x1.yaml --clips {args.clips} --frames {args.frames}` end to end "
        "(engine capture at 100 Hz, Mid-100 rendering, labels, Parquet, manifest). " + machine(),
        markdown_table(["run", "frames", "seconds", "frames/s", "speed-up"], rows),
        "Bytes per frame (paper_x1 frames; the KITTI-style formats from one clip):",
        markdown_table(["format", "bytes/frame", "ratio to raw"], sizes),
    )


if __name__ == "__main__":
    main()
