"""Pairs per second of train.geometry's IoU and DIoU matrices against shapely on the same pairs.

Layouts: ``pitch`` spreads N players' boxes (0.6 x 0.6 x 1.8 m) over the 105 x 68 m pitch and
compares them with the same boxes jittered, as the tracker does each frame; ``dense`` puts
every box within 1 m of the centre spot, so that every pair overlaps and is clipped. Ours skips
the pairs that cannot overlap (circumscribed circles apart). The baseline prunes too, as a shapely
user would: an `STRtree` of one side's polygons is queried with the other's, and only the pairs
whose rectangles intersect are intersected; for 3D it multiplies by the vertical overlap and for
DIoU it adds the 8 x 8 corner distances in numpy. For reference, shapely intersecting every pair
(no pruning) is timed too.

Usage: .venv/bin/python benchmarks/bench_geometry.py [--out benchmarks/results/geometry.md]
"""

import argparse
import functools
import time
import timeit
from collections.abc import Callable
from pathlib import Path

import numpy as np
import shapely
from table import machine, markdown_table, row, write_results

from train.geometry import bev_corners, bev_iou, diou_3d, iou_3d

PITCH_HALF_M = (52.5, 34.0)
CASES = [("pitch", 22), ("pitch", 200), ("dense", 22), ("dense", 200)]
REPEATS = 5  # timing runs of at least 0.2 s each; the best counts

Matrix = Callable[[np.ndarray, np.ndarray], np.ndarray]


def players(layout: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Tracks and jittered detections, (n, 7) each."""
    spread = np.array(PITCH_HALF_M) if layout == "pitch" else np.array([0.5, 0.5])
    centres = rng.uniform(-spread, spread, (n, 2))
    sizes = np.tile([0.6, 0.6, 1.8], (n, 1))
    tracks = np.column_stack([centres, np.full(n, 0.9), sizes, rng.uniform(-np.pi, np.pi, n)])
    jitter = np.column_stack([rng.normal(0, 0.1, (n, 3)), np.zeros((n, 3)), rng.normal(0, 0.2, n)])
    return tracks, tracks + jitter


def shapely_bev(a: np.ndarray, b: np.ndarray, prune: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Intersection areas (P, Q) and union areas (P, Q) in m^2 by shapely; pairs found by an STRtree
    (prune) or all of them."""
    poly_a, poly_b = shapely.polygons(bev_corners(a)), shapely.polygons(bev_corners(b))
    if prune:
        inter = np.zeros((len(a), len(b)))
        i, j = shapely.STRtree(poly_b).query(poly_a, predicate="intersects")
        inter[i, j] = shapely.area(shapely.intersection(poly_a[i], poly_b[j]))
    else:
        inter = shapely.area(shapely.intersection(poly_a[:, None], poly_b[None]))
    return inter, shapely.area(poly_a)[:, None] + shapely.area(poly_b)[None] - inter


def shapely_iou_3d(a: np.ndarray, b: np.ndarray, prune: bool = True) -> np.ndarray:
    inter, _ = shapely_bev(a, b, prune)
    top = np.minimum(a[:, None, 2] + a[:, None, 5] / 2, b[None, :, 2] + b[None, :, 5] / 2)
    bottom = np.maximum(a[:, None, 2] - a[:, None, 5] / 2, b[None, :, 2] - b[None, :, 5] / 2)
    inter = inter * np.maximum(top - bottom, 0.0)
    volume_a, volume_b = np.prod(a[:, 3:6], axis=1), np.prod(b[:, 3:6], axis=1)
    return inter / (volume_a[:, None] + volume_b[None] - inter)


def shapely_bev_iou(a: np.ndarray, b: np.ndarray, prune: bool = True) -> np.ndarray:
    inter, union = shapely_bev(a, b, prune)
    return inter / union


def shapely_diou_3d(a: np.ndarray, b: np.ndarray, prune: bool = True) -> np.ndarray:
    def corners_3d(boxes: np.ndarray) -> np.ndarray:
        flat = np.repeat(bev_corners(boxes), 2, axis=1)
        heights = boxes[:, None, 2] + np.tile([-0.5, 0.5], 4) * boxes[:, None, 5]
        return np.concatenate([flat, heights[..., None]], axis=-1)  # (N, 8, 3)

    gaps = corners_3d(a)[:, None, :, None] - corners_3d(b)[None, :, None]
    spread = np.max(np.sum(gaps**2, axis=-1), axis=(2, 3))
    centre_gap = np.sum((a[:, None, :3] - b[None, :, :3]) ** 2, axis=-1)
    return shapely_iou_3d(a, b, prune) - centre_gap / spread


def seconds_per_call(fn: Matrix, a: np.ndarray, b: np.ndarray) -> float:
    """CPU seconds of this process per call: load from other processes does not count."""
    timer = timeit.Timer(lambda: fn(a, b), timer=time.process_time)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=REPEATS, number=number)) / number


OPS: list[tuple[str, Matrix, Matrix]] = [
    ("bev_iou", bev_iou, shapely_bev_iou),
    ("iou_3d", iou_3d, shapely_iou_3d),
    ("diou_3d", diou_3d, shapely_diou_3d),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/geometry.md)")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    rows = []
    for layout, n in CASES:
        a, b = players(layout, n, rng)
        for name, ours, baseline in OPS:
            unpruned = functools.partial(baseline, prune=False)
            for theirs in (baseline, unpruned):
                np.testing.assert_allclose(ours(a, b), theirs(a, b), rtol=0, atol=1e-9)
            mine, pruned_s, all_s = (seconds_per_call(fn, a, b) for fn in (ours, baseline, unpruned))
            pairs = n * n
            rows.append(
                [
                    name,
                    f"{n}x{n}",
                    layout,
                    f"{mine * 1e6:,.0f}",
                    f"{pairs / mine:,.0f}",
                    f"{pairs / pruned_s:,.0f}",
                    f"{pruned_s / mine:.1f}x",
                    f"{pairs / all_s:,.0f}",
                    f"{all_s / mine:.1f}x",
                ]
            )
            print(row(rows[-1]), flush=True)
    write_results(
        "geometry",
        "train.geometry benchmark",
        f"Written by `benchmarks/bench_geometry.py`; best of {REPEATS} timing runs, in CPU time of the process. "
        + machine(numpy=np.__version__, shapely=shapely.__version__),
        "`pitch`: 22 or 200 players over the pitch against the same boxes jittered (few pairs overlap, most are "
        "pruned); `dense`: all within 1 m of one spot (every pair is clipped). Ours skips pairs whose circumscribed "
        "circles are apart. Baseline: shapely with the same pruning, as a shapely user would do it (an `STRtree` "
        "query, then polygon intersection of the pairs it finds only); the last two columns: shapely intersecting "
        "every pair, unpruned. For DIoU the baseline takes the 8 x 8 corner distances of every pair in numpy, ours "
        "their closed form: most of `diou_3d`'s ratio at 200 players.",
        markdown_table(
            ["op", "pairs", "layout", "us per call", "pairs/s", "shapely + STRtree pairs/s", "speed-up",
             "shapely unpruned pairs/s", "vs unpruned"],
            rows,
            left=3,
        ),
        out=args.out,
    )


if __name__ == "__main__":
    main()
