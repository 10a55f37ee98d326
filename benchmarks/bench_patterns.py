"""Shots generated per second by each scan pattern, against np.sin on as many float64 values.

Each case generates one window of shots (times and head-frame unit directions, as the renderer
gets them) with `scan_patterns.head_shots`, or a whole sensor's frame with `frame_shots`. The
baseline, measured in the same run, is the bare cost of `np.sin` over the same number of float64
values (one transcendental call per shot, no allocation of the result): ratio = shots/s divided by
np.sin values/s, so 1.0 means a shot costs as much as one float64 sine.

Usage: .venv/bin/python benchmarks/bench_patterns.py [--out benchmarks/results/patterns.md]
"""

import argparse
import timeit
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from table import machine, markdown_table, row, write_results

import scan_patterns as sp

REPEATS = 5  # timing runs of at least 0.2 s each; the best counts
WINDOW_S = 1.0  # 100,000 shots per head at x1
TARGET_RISLEY_SHOTS_PER_S = 20e6


def seconds_per_call(fn: Callable[[], object]) -> float:
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=REPEATS, number=number)) / number


def cases() -> list[tuple[str, str, Callable[[], sp.Shots]]]:
    head = {name: sp.get_sensor(name).heads[0] for name in ("mid40-risley", "mid40-rose", "mid40-replay")}
    mid100 = sp.get_sensor("mid100-risley")
    return [
        ("risley", "Mid-40 head, 1 s at x1", lambda: sp.head_shots(head["mid40-risley"], 10.0, 10.0 + WINDOW_S)),
        ("risley", "Mid-40 head, 1 s at x4", lambda: sp.head_shots(head["mid40-risley"], 10.0, 10.0 + WINDOW_S, 4.0)),
        ("rose", "Mid-40 head, 1 s at x1", lambda: sp.head_shots(head["mid40-rose"], 10.0, 10.0 + WINDOW_S)),
        ("replay", "Mid-40 file, 1 s at x1", lambda: sp.head_shots(head["mid40-replay"], 1.0, 1.0 + WINDOW_S)),
        ("replay", "Mid-40 file, 1 s at x2", lambda: sp.head_shots(head["mid40-replay"], 1.0, 1.0 + WINDOW_S, 2.0)),
        ("mid100-risley", "10 Hz frame at x2, 3 heads yawed", lambda: sp.frame_shots(mid100, 100, 10.0, 2.0)),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/patterns.md)")
    args = parser.parse_args()
    warnings.simplefilter("error", sp.PatternLoopWarning)  # the windows stay inside the file
    rows = []
    risley_rates = []
    for pattern, case, generate in cases():
        n = len(generate())
        values = np.random.default_rng(0).uniform(0, 2 * np.pi, n)
        out = np.empty_like(values)
        baseline = seconds_per_call(lambda: np.sin(values, out=out))
        mine = seconds_per_call(generate)
        if pattern == "risley":
            risley_rates.append(n / mine)
        rows.append([pattern, case, f"{n:,}", f"{mine * 1e3:.2f}", f"{n / mine / 1e6:.1f}", f"{n / baseline / 1e6:.1f}",
                     f"{baseline / mine:.2f}"])
        print(row(rows[-1]), flush=True)
    verdict = "met" if min(risley_rates) >= TARGET_RISLEY_SHOTS_PER_S else "NOT met"
    write_results(
        "patterns",
        "scan_patterns benchmark",
        f"Written by `benchmarks/bench_patterns.py`; best of {REPEATS} timing runs. " + machine(numpy=np.__version__),
        "A shot is its time (float64) and head-frame unit direction (float32), as the renderer gets "
        "them. Baseline: `np.sin` over the same number of float64 values, in the same run; ratio = "
        "shots/s / sines/s (1.0: a shot costs one float64 sine).\n"
        f"Target for `risley`: at least {TARGET_RISLEY_SHOTS_PER_S / 1e6:.0f} M shots/s ({verdict}).",
        markdown_table(["pattern", "case", "shots", "ms per call", "M shots/s", "M np.sin/s (baseline)", "ratio"], rows, left=2),
        out=args.out,
    )


if __name__ == "__main__":
    main()
