"""Online tracking benchmark: per-frame latency of each stage of `simgen-train track --online`, one core, and the
tracker alone against AB3DMOT's config.

1. Detector + tracker, frame by frame as a sensor delivers them (train.track.run, online): the compact late
   model (train/configs/late.yaml) and the paper's full tracker on a generated paper_x1 clip (11 Hz) read
   from its ROS 2 bag (`simgen export`, each frame's cloud decoded as it comes, as from a sensor),
   one torch thread, BLAS threads 1. The weights are untrained, so its inference keeps every candidate
   (score threshold 0) up to `--detections` boxes a frame after NMS (default 47: what the paper_x1 study's
   trained model gave per val frame, studies/paper_x1_1200/table2.md), and the tracker sees them through
   the default filter at score 0 (centres 1 m apart): the work a trained model's output costs. Reported:
   p50 / p99 / max of read, pillars, network, decode, track and their total per frame in CPU time of the
   thread (the shared machine's load left out), after the network's warm-up; the real-time factor at 11 Hz
   (CPU time per frame over one period, mean and p99: under 1 keeps up); and the same frames paced at 11 Hz
   in wall time (`--rate 11`), counting late and dropped frames at the machine's load.
2. The tracker alone, 25 players (tests.support.tracking_clips, noisy tracklets), frames/s of process CPU
   time, median of rounds alternating: the paper's full tracker against AB3DMOT's algorithm as configured
   here (1_ab3dmot.yaml; AB3DMOT's own code is not on PyPI, see bench_tracking.py).

Writes benchmarks/results/track.md; `--tracker-only` measures 2. alone and rewrites only its section there.

Usage: .venv/bin/python benchmarks/bench_track.py [--frames 60] [--rounds 5] [--tracker-only]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from table import RESULTS_DIR, machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support.trackers import AB3DMOT, FULL_TRACKER, shipped_tracker
from tests.support.tracking_clips import NOISY_DETECTOR, PlayersConfig, make_tracklets, simulate_players
from train.config import load_config, parse_config
from train.detector.model import Detector
from train.study.tracklet_filter import TrackletFilter
from train.track.latency import STAGES
from train.track.run import DEFAULT_FILTER, Model, TrackOptions, run_track
from train.tracking.tracker import Tracker

RATE_HZ = 11.0
PLAYERS = 25
TRACKER_SECTION = "\n\nThe tracker alone, "  # the results file's last section, from this paragraph to the end


def make_bag(folder: Path, frames: int) -> Path:
    """One clip of the paper's x1 scenario, as a sensor's ROS 2 bag (`simgen export`)."""
    out, bag = folder / "paper_x1", folder / "clip_0000.mcap"
    for command in (["generate", str(ROOT / "scenarios" / "paper_x1.yaml"), "-o", str(out), "--frames", str(frames),
                     "--clips", "1"], ["export", str(out), "-o", str(bag)]):
        subprocess.run([sys.executable, "-m", "simgen.cli", *command], check=True, capture_output=True, cwd=ROOT)
    return bag


def compact_late(detections: int) -> Model:
    """The compact late model, untrained, keeping its `detections` best boxes a frame (of 3 x as many
    candidates)."""
    data = load_config(ROOT / "train" / "configs" / "late.yaml").model_dump(mode="json")
    data["infer"].update(score_threshold=0.0, pre_nms=3 * detections, max_detections=detections)
    config = parse_config(data, "late.yaml (benchmark)")
    torch.manual_seed(0)
    return Model(Detector(config).eval(), config)


def online(bag: Path, out: Path, model: Model, rate_hz: float | None, clock: Callable[[], float]):
    options = TrackOptions(out, shipped_tracker(FULL_TRACKER), None, bag, "simgen", model, None, None, None,
                           True, rate_hz, 64, TrackletFilter(0.0, "centre", DEFAULT_FILTER.nms_threshold),
                           torch.device("cpu"), False, clock)
    return run_track(options, lambda folder, result: None)


def tracker_rates(frames: int, rounds: int) -> dict[str, float]:
    """Frames/s of CPU time of the full tracker and of AB3DMOT's config, 25 players, median of `rounds`."""
    clip = simulate_players(PlayersConfig(n_players=PLAYERS, n_frames=frames), np.random.default_rng(0))
    tracklets = make_tracklets(clip, NOISY_DETECTOR, np.random.default_rng(1))
    configs = {"AB3DMOT": shipped_tracker(AB3DMOT), "full": shipped_tracker(FULL_TRACKER)}
    rates: dict[str, list[float]] = {name: [] for name in configs}
    for _ in range(rounds):
        for name, config in configs.items():
            tracker = Tracker(config)
            started = time.process_time()
            for t in tracklets:
                tracker.step(t)
            rates[name].append(frames / (time.process_time() - started))
    return {name: statistics.median(r) for name, r in rates.items()}


def tracker_section(frames: int, rounds: int) -> str:
    """The tracker-alone paragraph and table of the results file, measured now (starts with TRACKER_SECTION)."""
    rates = tracker_rates(frames, rounds)
    rows = [["AB3DMOT's algorithm (1_ab3dmot.yaml)", f"{rates['AB3DMOT']:,.0f}", "1.00"],
            ["the paper's full tracker (5_diou_birth_death_split.yaml)", f"{rates['full']:,.0f}",
             f"{rates['full'] / rates['AB3DMOT']:.2f}"]]
    for cells in rows:
        print(cells, flush=True)
    return (
        f"{TRACKER_SECTION}{PLAYERS} players, {frames} frames of noisy tracklets (tests.support.tracking_clips), "
        f"frames/s of process CPU time, median of {rounds} rounds alternating, at load {os.getloadavg()[0]:.1f}:"
        f"\n\n{markdown_table(['tracker', 'frames/s', 'ratio to AB3DMOT'], rows)}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames of the paper_x1 clip")
    parser.add_argument("--detections", type=int, default=47, help="boxes a frame the detector keeps")
    parser.add_argument("--tracker-frames", type=int, default=600)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/track.md)")
    parser.add_argument("--tracker-only", action="store_true",
                        help="measure the tracker alone and rewrite only its section of the results file, "
                             "keeping the rest (the file must hold one, written by a full run)")
    args = parser.parse_args()
    if args.tracker_only:
        path = args.out or RESULTS_DIR / "track.md"
        head, found, _ = (path.read_text() if path.is_file() else "").partition(TRACKER_SECTION)
        if not found:
            parser.error(f"{path}: no tracker section to replace; run bench_track.py without --tracker-only first")
        path.write_text(head + tracker_section(args.tracker_frames, args.rounds) + "\n")
        print(f"wrote {path}", flush=True)
        return
    torch.set_num_threads(1)
    model = compact_late(args.detections)
    with tempfile.TemporaryDirectory() as folder:
        bag = make_bag(Path(folder), args.frames)
        free = online(bag, Path(folder) / "free", model, None, time.process_time)
        paced = online(bag, Path(folder) / "paced", model, RATE_HZ, time.perf_counter)
    table = np.array([[ms[s] for s in STAGES] for _, _, ms in free.latency.rows])
    total = table.sum(axis=1)
    period_ms = 1000.0 / RATE_HZ
    columns = [*zip(STAGES, table.T), ("total", total)]
    latency_rows = [[name, f"{np.percentile(v, 50):.1f}", f"{np.percentile(v, 99):.1f}", f"{v.max():.1f}"]
                    for name, v in columns]
    rtf = f"{total.mean() / period_ms:.2f} (p99 {np.percentile(total, 99) / period_ms:.2f})"
    for cells in latency_rows:
        print(cells, flush=True)
    tracker = tracker_section(args.tracker_frames, args.rounds)
    write_results(
        "track", "Online tracking benchmark",
        f"Written by `benchmarks/bench_track.py`: one paper_x1 clip of {args.frames} frames read from its ROS 2 bag "
        f"(tracked from frame 2, the "
        f"late model's first window; frames 0 and 1 computed as they arrive, and timed), the compact late model "
        f"(untrained, keeping its {args.detections} best boxes a frame) and the paper's full tracker, "
        f"`track --online`, one torch thread, BLAS threads 1. {machine(torch=torch.__version__, numpy=np.__version__)}",
        "Latency per frame (ms of the process's CPU time: the shared machine's load left out), after the network's "
        "warm-up:",
        markdown_table(["stage", "p50", "p99", "max"], latency_rows),
        f"Real-time factor at {RATE_HZ:g} Hz (CPU time per frame over one {period_ms:.1f} ms period; under 1 keeps "
        f"up): {rtf}. Paced at {RATE_HZ:g} Hz (`--rate {RATE_HZ:g}`, wall time, at this load): {paced.late} of "
        f"{paced.frames + paced.dropped} frames late, {paced.dropped} dropped." + tracker,
        out=args.out,
    )


if __name__ == "__main__":
    main()
