"""The study's tracklet-filter choice: its wall time in this tree, serial and in processes, against a baseline revision.

What the study does before Table 2 (train.study.tracklet_filter.choose_filters): every tracker of
train/configs/tracking/ tracks the tracklets under each of the 20 filters of GRID and is scored (sAMOTA) against
the labels. Here on one synthetic clip of the val clip's length (tests.support.tracking_clips: 22 players, 203
frames at 10 Hz, the FLOOD detector with one near-duplicate a player: about 40 tracklets a frame, as the
paper-size late model's val clip has 37.8). The baseline revision's `train` (default 65f1b3b, before the
evaluation counted on arrays and the filters ran in processes) is unpacked from git into a temporary folder;
each run is a child process with that tree's packages, BLAS threads 1, the clips handed over as a pickle of
train.tracking.types objects; the runs alternate so that load on the shared machine hits all alike. Every run
must choose the same filters with the same sAMOTA (checked). Writes benchmarks/results/filter_choice.md.

Usage: .venv/bin/python benchmarks/bench_filter_choice.py [--baseline 65f1b3b] [--rounds 2] [--workers 2]
"""

from __future__ import annotations

import argparse
import io
import os
import pickle
import statistics
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from table import machine, markdown_table, row, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this tree's packages, and tests.support's synthetic clips

from tests.support.tracking_clips import FLOOD, PlayersConfig, make_tracklets, simulate_players

# The child: load the clips, time choose_filters on the study's grid, print wall and CPU seconds and the choice.
CHILD = """
import inspect, pickle, sys, time
from train.study.tracklet_filter import GRID, choose_filters
from train.study.run import TRACKER_CONFIGS
from train.tracking.config import load_tracker_configs
clips, truth = pickle.load(open(sys.argv[1], "rb"))
workers = int(sys.argv[2])
options = {"workers": workers} if "workers" in inspect.signature(choose_filters).parameters else {}
configs = load_tracker_configs(TRACKER_CONFIGS)
wall, cpu = time.perf_counter(), time.process_time()
chosen = choose_filters(clips, truth, configs, GRID, **options)
print(time.perf_counter() - wall, time.process_time() - cpu)
print(sorted((name, rule.label, round(scores[GRID.index(rule)].samota, 9)) for name, (rule, scores) in chosen.items()))
"""


def unpack(revision: str, folder: Path) -> Path:
    """This repository's `train` and `simgen` at `revision`, in `folder`."""
    archive = subprocess.run(["git", "archive", "--format=tar", revision, "train", "simgen", "scan_patterns"],
                             cwd=ROOT, check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    return folder


def run(tree: Path, clips: Path, workers: int) -> tuple[float, float, str]:
    """(wall s, CPU s of the parent process, the choice) of one choose_filters in a child with `tree`'s packages."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", CHILD, str(clips), str(workers)], cwd=tree, env=env, check=True,
                          capture_output=True, text=True)
    times, choice = done.stdout.strip().splitlines()[-2:]
    wall, cpu = map(float, times.split())
    return wall, cpu, choice


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="65f1b3b", help="git revision to compare with (default 65f1b3b)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--workers", type=int, default=2, help="processes of the parallel run (default 2)")
    parser.add_argument("--frames", type=int, default=203)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/"
                        "filter_choice.md)")
    args = parser.parse_args()

    players = simulate_players(PlayersConfig(n_frames=args.frames), np.random.default_rng(args.seed))
    detector = replace(FLOOD, near_duplicates=1.0)
    tracklets = make_tracklets(players, detector, np.random.default_rng(args.seed + 1))
    per_frame = np.mean([len(t.scores) for t in tracklets])
    with tempfile.TemporaryDirectory() as scratch:
        clips = Path(scratch) / "clips.pkl"
        clips.write_bytes(pickle.dumps(([tracklets], [players.frames()])))
        runs = {"baseline": (unpack(args.baseline, Path(scratch) / "baseline"), 1), "this tree": (ROOT, 1),
                f"this tree, {args.workers} processes": (ROOT, args.workers)}
        walls: dict[str, list[float]] = {name: [] for name in runs}
        cpus: dict[str, list[float]] = {name: [] for name in runs}
        choices = set()
        for _ in range(args.rounds):
            for name, (tree, workers) in runs.items():
                wall, cpu, choice = run(tree, clips, workers)
                walls[name].append(wall)
                cpus[name].append(cpu)
                choices.add(choice)
                print(row([name, f"{wall:.1f}", f"{cpu:.1f}"]), flush=True)
    if len(choices) != 1:
        raise SystemExit(f"the runs chose differently: {choices}")
    base = statistics.median(walls["baseline"])
    rows = [[name, f"{statistics.median(walls[name]):.1f}", f"{statistics.median(cpus[name]):.1f}",
             f"{base / statistics.median(walls[name]):.2f}"] for name in runs]
    write_results(
        "filter_choice",
        "The study's tracklet-filter choice",
        f"Written by `benchmarks/bench_filter_choice.py`: the study's 20 filters x 6 trackers of "
        f"train/configs/tracking/ on one synthetic clip of 22 players, {args.frames} frames (seed {args.seed}), "
        f"{per_frame:.1f} tracklets a frame; median of {args.rounds} rounds, the runs alternating; each a child "
        f"process, BLAS threads 1. Baseline: revision {args.baseline}, the same work; every run chose the same "
        f"filters with the same sAMOTA. " + machine(numpy=np.__version__),
        "Wall seconds of `choose_filters` (CPU seconds: the parent process only, its workers' not counted).",
        markdown_table(["run", "wall s", "CPU s", "speed-up (wall)"], rows),
        out=args.out,
    )


if __name__ == "__main__":
    main()
