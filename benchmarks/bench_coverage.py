"""Coverage benchmark: how long `simgen coverage`'s standing grid takes per rig, one process.

For the paper's rig and every shipped whole-pitch rig: a standing player at every cell of a 1 m grid over the
pitch (7,140 cells) in 4 headings (`simgen.coverage.grid.grid_coverage`, the command's defaults), with the time,
the frames rendered, the players per frame and the share of the pitch where a standing player gets 5 points or
more per frame. Writes benchmarks/results/coverage.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from table import machine, markdown_table, write_results

from simgen.coverage.grid import grid_coverage
from simgen.coverage.summary import in_area, share_at_least
from simgen.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
RIGS = ("paper_x1", "whole_mid100_goals", "whole_mid100_touchlines", "whole_hap_goals", "modern_mid360")
HEADINGS_DEG = np.array([0.0, 90.0, 180.0, 270.0])


def main() -> None:
    grid_coverage(load_scenario(ROOT / "scenarios" / "paper_x1.yaml"), 30.0, HEADINGS_DEG)  # numba's compiled cache
    rows = []
    for name in RIGS:
        scenario = load_scenario(ROOT / "scenarios" / f"{name}.yaml")
        started = time.perf_counter()
        coverage = grid_coverage(scenario, 1.0, HEADINGS_DEG)
        seconds = time.perf_counter() - started
        cells = len(coverage.grid.centres_m)
        paper = in_area(coverage.grid.centres_m, "paper")
        rows.append((
            name, len(scenario.sensors), f"{cells:,}", f"{coverage.frames:,}",
            f"{cells * len(HEADINGS_DEG) / coverage.frames:.1f}", f"{seconds:.1f}",
            f"{100 * share_at_least(coverage.rig_mean, 5):.1f} %",
            f"{100 * share_at_least(coverage.rig_mean[paper], 5):.1f} %",
        ))
    write_results(
        "coverage",
        "Coverage benchmark",
        markdown_table(
            ("rig", "sensors", "cells", "frames", "players per frame", "seconds, 1 process",
             "pitch >= 5 points", "paper box >= 5 points"),
            rows,
        ),
        "A standing player at every cell of a 1 m grid over the pitch in 4 headings (the defaults of `simgen "
        "coverage`), each rig's scan, noise and goals; players rendered together in a frame never share a ray "
        "(tests/test_coverage.py). The last columns: share of the cells (of the whole pitch, of the paper's [-40, 40] "
        "m box) where a standing player gets 5 points or more per frame, mean over headings. "
        + machine(numpy=np.__version__),
    )


if __name__ == "__main__":
    main()
