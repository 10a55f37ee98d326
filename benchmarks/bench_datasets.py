"""Bytes per frame and write / read frames per second of each dataset format, against what a user would pick.

Frames shaped like a Mid-100 x1 frame: about 25,000 points and 25 humanoids, from
tests/support/datasets.py (synthetic: ground points round a sensor at the touchline with 2 cm
range noise, points on the humanoids, random intensities; real scans compress somewhat
differently). Write: `write_clip` + `finish_dataset` of one clip (every file hashed for the
manifest). Read: `simgen.datasets.open` and every frame's points, with every file's sha256 checked
(the default) and without (`verify=False`). Baselines, on the same frames in the same run, holding
the same fields: `numpy.savez_compressed` of every array of the frame (points and labels), one file
per frame, read back with `numpy.load` (the ratios are against it); and the same Parquet tables as
ours written with pyarrow's defaults (`pq.write_table`: snappy, no byte-stream-split), read back
with `pq.read_table` and split into frames.

Usage: .venv/bin/python benchmarks/bench_datasets.py [--frames 40] [--out benchmarks/results/datasets.md]
"""

from __future__ import annotations

import argparse
import functools
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow
import pyarrow.parquet as pq
from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this tree's packages, and tests.support's synthetic frames

import simgen.datasets
from simgen.datasets import FORMATS, finish_dataset, write_clip
from simgen.datasets.formats import parquet
from tests.support.datasets import make_clip, sensors

POINTS = 25_000
HUMANOIDS = 25
REPEATS = 5  # the best run counts


def best_seconds(run: Callable[[], None], reset: Callable[[], None]) -> float:
    """Best CPU seconds of this process for run, reset before each: load from other processes does not count."""
    times = []
    for _ in range(REPEATS):
        reset()
        started = time.process_time()
        run()
        times.append(time.process_time() - started)
    return min(times)


def best_alternating(runs: list[Callable[[], None]]) -> list[float]:
    """Best CPU seconds of each run, the runs taking turns so that the machine's load hits them alike."""
    times: list[list[float]] = [[] for _ in runs]
    for _ in range(REPEATS):
        for run, spent in zip(runs, times):
            started = time.process_time()
            run()
            spent.append(time.process_time() - started)
    return [min(spent) for spent in times]


def write_npz(root: Path, frames) -> None:
    root.mkdir(parents=True, exist_ok=True)
    for frame in frames:
        arrays = {
            **{f"scan_{k}": v for k, v in vars(frame.scan).items() if isinstance(v, np.ndarray)},
            **vars(frame.labels),
        }
        np.savez_compressed(root / f"{frame.index:06d}.npz", **arrays)


def read_npz(root: Path) -> None:
    for path in sorted(root.glob("*.npz")):
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        arrays["scan_points_m"].sum()


def write_parquet_defaults(root: Path, frames) -> None:
    """Our four tables, each one file written with pyarrow's default options."""
    root.mkdir(parents=True, exist_ok=True)
    tables = {
        "frames": parquet.frames_table(frames[0].clip, [parquet.frame_row(frame) for frame in frames]),
        "points": pyarrow.concat_tables(parquet.points_table(frame) for frame in frames),
        "boxes": parquet.boxes_table(
            frames[0].clip, [frame.index for frame in frames], [frame.labels for frame in frames]
        ),
        "sensors": parquet.sensors_table(sensors()),
    }
    for name, table in tables.items():
        pq.write_table(table, root / f"{name}.parquet")


def read_parquet_defaults(root: Path) -> None:
    tables = {path.stem: pq.read_table(path) for path in root.glob("*.parquet")}
    points = tables["points"]
    xyz = np.column_stack([points[axis].to_numpy() for axis in "xyz"])
    for frame_points in np.split(xyz, np.cumsum(tables["frames"]["num_points"].to_numpy())[:-1]):
        frame_points.sum()
    for table in tables.values():
        for column in table.columns:
            column.to_numpy()


def read_dataset(root: Path, verify: bool = True) -> None:
    for frame in simgen.datasets.open_dataset(root, verify):
        frame.points_m.sum()


Case = tuple[str, Callable[[Path], None], Callable[[Path], None], Callable[[Path], None]]


def measure(frames, work: Path) -> list[tuple[str, float, float, float, float]]:
    """(name, bytes per frame, write, read, unchecked read frames/s), the baseline first."""
    count = len(frames)
    cases: list[Case] = [
        ("numpy.savez_compressed (baseline)", lambda root: write_npz(root, frames), read_npz, read_npz),
        ("Parquet, pyarrow defaults", lambda root: write_parquet_defaults(root, frames), read_parquet_defaults,
         read_parquet_defaults),
    ]
    for format in FORMATS:
        def write(root: Path, format=format) -> None:
            record = write_clip(root, format, frames, sensors(), 0)
            finish_dataset(root, format, [record], sensors(), {"name": "bench"}, 0)

        cases.append((format, write, read_dataset, functools.partial(read_dataset, verify=False)))
    rows = []
    for index, (name, write, read, read_unchecked) in enumerate(cases):
        root = work / str(index)
        write_s = best_seconds(
            functools.partial(write, root), functools.partial(shutil.rmtree, root, ignore_errors=True)
        )
        if read_unchecked is read:
            read_s = unchecked_s = best_seconds(functools.partial(read, root), lambda: None)
        else:
            read_s, unchecked_s = best_alternating(
                [functools.partial(read, root), functools.partial(read_unchecked, root)]
            )
        size = sum(p.stat().st_size for p in root.rglob("*") if p.is_file())
        rows.append((name, size / count, count / write_s, count / read_s, count / unchecked_s))
        print(f"{name}: {size / count:,.0f} B/frame, {count / write_s:,.1f} written, {count / read_s:,.1f} read "
              f"({count / unchecked_s:,.1f} unchecked) per s", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/datasets.md)")
    args = parser.parse_args()
    frames = make_clip("clip_0000", args.frames, points=POINTS, humanoids=HUMANOIDS, seed=0)
    with tempfile.TemporaryDirectory() as work:
        rows = measure(frames, Path(work))
    base = rows[0][1:]
    table = [
        [name, *(f"{value:,.0f}" if i == 0 else f"{value:,.1f}" for i, value in enumerate(values)),
         *(f"{value / baseline:.2f}" for value, baseline in zip(values, base))]
        for name, *values in rows
    ]
    points = np.mean([len(f.scan.points_m) for f in frames])
    write_results(
        "datasets",
        "Dataset formats benchmark",
        f"Written by `benchmarks/bench_datasets.py`; {args.frames} frames of {points:,.0f} points and {HUMANOIDS} "
        f"humanoids on average, best of {REPEATS} runs in CPU time of the process (on a shared machine, wall time "
        "runs higher). " + machine(numpy=np.__version__, pyarrow=pyarrow.__version__),
        "Baselines, holding the same fields as our Parquet: every array of the frame (points and labels) in one "
        "`numpy.savez_compressed` per frame (the ratios are against it), and our Parquet tables written with "
        "pyarrow's defaults (`pq.write_table`: snappy, dictionary, plain floats; read with `pq.read_table`). Ours, "
        "`parquet`: zstd, byte-stream-split floats, points in row groups of 10 frames; KITTI and OpenPCDet hold x, y, "
        "z, intensity and the boxes. Our write includes hashing every file for the manifest and the dataset card; our "
        "read checks every file's sha256 (the default; the last columns: `verify=False`). The baselines do neither.",
        markdown_table(
            [
                "format",
                "bytes/frame",
                "write frames/s",
                "read frames/s",
                "read, sha256 unchecked",
                "bytes vs baseline",
                "write vs baseline",
                "read vs baseline",
                "unchecked read vs baseline",
            ],
            table,
        ),
        out=args.out,
    )


if __name__ == "__main__":
    main()
