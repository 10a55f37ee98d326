"""Bytes per frame and write / read frames per second of each dataset format, against raw numpy.

Frames shaped like a Mid-100 x1 frame: about 25,000 points and 25 humanoids, from
tests/dataset_factory.py (synthetic: ground points round a sensor at the touchline with 2 cm
range noise, points on the humanoids, random intensities; real scans compress somewhat
differently). Write: `write_clip` + `finish_dataset` of one clip (every file hashed for the
manifest). Read: `simgen.datasets.open` and every frame, sha256 of every file checked (the
default). Baseline, on the same frames in the same run: every array of the frame (points and
labels) in one uncompressed `numpy.savez` per frame, read back with `numpy.load`.

Usage: .venv/bin/python benchmarks/bench_datasets.py [--frames 40] [--out benchmarks/results/datasets.md]
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from dataset_factory import make_clip, sensors  # noqa: E402

import simgen.datasets  # noqa: E402
from simgen.datasets import FORMATS, finish_dataset, write_clip  # noqa: E402

POINTS = 25_000
HUMANOIDS = 25
REPEATS = 5  # the best run counts


def best_seconds(run: Callable[[], None], reset: Callable[[], None]) -> float:
    times = []
    for _ in range(REPEATS):
        reset()
        started = time.perf_counter()
        run()
        times.append(time.perf_counter() - started)
    return min(times)


def write_npz(root: Path, frames) -> None:
    root.mkdir(parents=True, exist_ok=True)
    for frame in frames:
        arrays = {**{f"scan_{k}": v for k, v in vars(frame.scan).items() if isinstance(v, np.ndarray)}, **vars(frame.labels)}
        np.savez(root / f"{frame.index:06d}.npz", **arrays)


def read_npz(root: Path) -> None:
    for path in sorted(root.glob("*.npz")):
        with np.load(path, allow_pickle=False) as data:
            for name in data.files:
                data[name]


def read_dataset(root: Path) -> None:
    for frame in simgen.datasets.open(root):
        frame.points_m.sum()


def measure(frames, work: Path) -> list[tuple[str, float, float, float]]:
    """(name, bytes per frame, write frames/s, read frames/s), the baseline first."""
    count = len(frames)
    rows = []
    cases = [("numpy.savez (baseline)", lambda root: write_npz(root, frames), read_npz)]
    for format in FORMATS:
        def write(root: Path, format=format) -> None:
            record = write_clip(root, format, frames, sensors(), 0)
            finish_dataset(root, format, [record], sensors(), {"name": "bench"}, 0)

        cases.append((format, write, read_dataset))
    for name, write, read in cases:
        root = work / name.split()[0]
        write_s = best_seconds(lambda: write(root), lambda: shutil.rmtree(root, ignore_errors=True))
        read_s = best_seconds(lambda: read(root), lambda: None)
        size = sum(p.stat().st_size for p in root.rglob("*") if p.is_file())
        rows.append((name, size / count, count / write_s, count / read_s))
        print(f"{name}: {size / count:,.0f} B/frame, {count / write_s:,.1f} written, {count / read_s:,.1f} read per s", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "datasets.md")
    args = parser.parse_args()
    frames = make_clip("clip_0000", args.frames, points=POINTS, humanoids=HUMANOIDS, seed=0)
    with tempfile.TemporaryDirectory() as work:
        rows = measure(frames, Path(work))
    _, base_bytes, base_write, base_read = rows[0]
    table = [
        f"| {name} | {size:,.0f} | {size / base_bytes:.2f} | {write:,.1f} | {write / base_write:.2f} "
        f"| {read:,.1f} | {read / base_read:.2f} |"
        for name, size, write, read in rows
    ]
    points = np.mean([len(f.scan.points_m) for f in frames])
    lines = [
        "# Dataset formats benchmark",
        "",
        f"Written by `benchmarks/bench_datasets.py`; {args.frames} frames of {points:,.0f} points and {HUMANOIDS} humanoids on "
        f"average, best of {REPEATS} runs. Python {platform.python_version()}, numpy {np.__version__}, pyarrow "
        f"{pyarrow.__version__}, {platform.machine()} with {os.cpu_count()} CPUs at load {os.getloadavg()[0]:.1f} (a shared "
        "machine: compare the ratios, not the absolute rates).",
        "",
        "Baseline: every array of the frame, points and labels, in one uncompressed `numpy.savez` per frame. Parquet holds "
        "all of it too (zstd, byte-stream-split floats); KITTI and OpenPCDet hold x, y, z, intensity and the boxes. Write "
        "includes hashing every file for the manifest; read includes checking every file's sha256.",
        "",
        "| format | bytes/frame | vs baseline | write frames/s | vs baseline | read frames/s | vs baseline |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
        *table,
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
