"""Capture benchmark: engine steps per second with our keypoint export vs without it.

Both run in this process on the same engine, alternating rounds so drift hits both alike:
- baseline: the engine stepping 100 ms (10 physics steps) with all players on built-in AI and
  reading its observation (`get_info`), our export switched off;
- capture: the same, plus recording all keypoints after every physics step and reading them into
  numpy (what `simgen capture` does per step).
Writes benchmarks/results/capture.md.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from table import machine, markdown_table, write_results

from simgen.motion.engine import FootballEngine
from simgen.scenario import MotionConfig


def _rate(engine: FootballEngine, steps: int, export: bool) -> float:
    engine._engine.set_keypoint_capture(export)
    started = time.perf_counter()
    for _ in range(steps):
        engine.step()
        engine.info()
        if export:
            engine.samples()
    return steps / (time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300, help="engine steps per round")
    parser.add_argument("--rounds", type=int, default=4)
    args = parser.parse_args()

    engine = FootballEngine(MotionConfig(), seed=3)
    _rate(engine, 50, True)  # warm-up: kick-off and caches
    baseline, capture = [], []
    for _ in range(args.rounds):
        baseline.append(_rate(engine, args.steps, False))
        capture.append(_rate(engine, args.steps, True))
    engine.close()
    base, cap = float(np.median(baseline)), float(np.median(capture))
    ratio = cap / base
    write_results(
        "capture",
        "Capture benchmark",
        markdown_table(
            ["measure", "steps/s (median)", "ratio to baseline"],
            [
                ["engine stepping, export off (baseline)", f"{base:.0f}", "1.00"],
                ["engine stepping + 12-keypoint export of 25 humanoids at 100 Hz", f"{cap:.0f}", f"{ratio:.2f}"],
            ],
        ),
        f"{args.rounds} rounds x {args.steps} steps (1 step = 100 ms of game time = 10 frames at 100 Hz), one core. "
        f"Export cost: {100 * (1 - ratio):.1f} %. " + machine(numpy=np.__version__),
    )


if __name__ == "__main__":
    main()
