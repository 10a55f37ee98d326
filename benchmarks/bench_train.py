"""Training speed: samples per second of `simgen-train fit`, a step's time by phase, and the val pass.

What a user runs, measured against the same work done by a baseline revision of this repository
(default d2bfbe4, before the training step was made sparse and free of host synchronisation), in
the same run: the baseline's `simgen`, `train` and `scan_patterns` are unpacked from git into a
temporary folder, each tree generates its own paper_x1 (the baseline reads only its own schema),
and the two trees' `fit` and `eval` run as child processes, alternating, one torch thread each (as
the CPU studies run two fits side by side on two cores).

- `fit`: compact late (train/configs/late.yaml, batch 2, one loader process), ITERATIONS
  iterations, no evaluation; samples/s as the fit's own log reports it (loading included).
- step breakdown (this tree): the same loop in this process, each phase timed: waiting for the
  loader, forward, backward (with the loss), optimiser (on CUDA, synchronised at each phase for the
  breakdown only).
- val pass: each tree's `predict` (inference, loading included) and AP (visible boxes found, AP on all
  and visible boxes at t, t-1 and t-2) on paper_x1's 203 val frames with its own checkpoint, in a
  child process (imports and checkpoint loading not counted): CPU seconds of the child and its loader
  processes, one torch thread (CPU seconds hold under load; on a shared machine two OpenMP threads
  waiting on each other measure the load, not the code).
- paper-size configs (train/configs/paper/): samples/s of a few iterations of this tree, on CPU,
  and on CUDA when present.

Writes benchmarks/results/train.md.

Usage: .venv/bin/python benchmarks/bench_train.py [--baseline d2bfbe4] [--iterations 40] [--rounds 2]
       [--paper-iterations 3]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import csv
import io
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import torch
import yaml
from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from train.config import parse_config
from train.data import SampleSet, loader
from train.detector.losses import detection_loss
from train.detector.model import build_detector
from train.fit import autocast

PACKAGES = ("simgen", "train", "scan_patterns")


def unpack(revision: str, folder: Path) -> Path:
    """This repository's packages and scenarios at `revision`, in `folder`."""
    archive = subprocess.run(["git", "archive", "--format=tar", revision, *PACKAGES, "scenarios"], cwd=ROOT, check=True,
                             capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(folder, filter="data")
    return folder


def child(tree: Path, *arguments: str) -> None:
    """`python -m ARGUMENTS` with `tree`'s packages, one torch thread."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    subprocess.run([sys.executable, "-m", *arguments], cwd=tree, env=env, check=True, capture_output=True)


def compact_late(tree: Path, iterations: int, out: Path) -> Path:
    """`tree`'s compact late config with `iterations`, no evaluation, one loader process."""
    raw = yaml.safe_load((tree / "train" / "configs" / "late.yaml").read_text())
    raw["train"].update(iterations=iterations, eval_every=0, workers=1, checkpoint_every=10 * iterations)
    path = out / "late.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def fit_rate(tree: Path, config: Path, dataset: Path, out: Path) -> float:
    """Samples/s of `fit` as its train_log.csv states it."""
    child(tree, "train.cli", "fit", str(config), "--dataset", str(dataset), "-o", str(out), "--quiet")
    with open(out / "train_log.csv") as log:
        return float(list(csv.DictReader(log))[-1]["samples_per_s"])


def step_breakdown(config_path: Path, dataset: Path, steps: int, device: torch.device) -> dict[str, float]:
    """Mean seconds per step of each phase, after two warm-up steps."""
    config = parse_config(yaml.safe_load(config_path.read_text()))
    model = build_detector(config).to(device).train()
    samples = SampleSet(
        str(dataset), "train", config, draws=(steps + 2) * config.train.batch_size, assign=model.head.assigner
    )
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.train.lr)
    batches = loader(samples, config.train.batch_size, 1, model.head.assigner.collate, pin_memory=device.type == "cuda")
    phases = {"waiting for data": 0.0, "forward": 0.0, "backward": 0.0, "optimiser": 0.0}

    def mark() -> float:
        if device.type == "cuda":
            torch.cuda.synchronize()
        return time.perf_counter()

    for step in range(steps + 2):
        start = mark()
        batch = next(batches).to(device, non_blocking=True)
        loaded = mark()
        with autocast(device, config.train.bf16):
            output = model(batch)
        forward = mark()
        terms = detection_loss(output.float(), batch.targets, config.loss)
        optimizer.zero_grad(set_to_none=True)
        terms.total.backward()
        backward = mark()
        torch.nn.utils.clip_grad_norm_(model.parameters(), config.train.grad_clip)
        optimizer.step()
        done = mark()
        if step >= 2:
            for name, seconds in zip(phases, (loaded - start, forward - loaded, backward - forward, done - backward)):
                phases[name] += seconds / steps
    return phases


VAL_PASS = """
import resource, sys, time
import torch
import simgen.datasets
from train.checkpoint import load_checkpoint
try:  # this tree's layout
    from train.detector.inference import predict
    from train.detector.model import build_detector
    from train.evaluation.ap_table import average_precisions, visible_objects
except ImportError:  # the baseline's flat modules (d2bfbe4)
    from train.evaluate import average_precisions, predict, visible_objects
    from train.models.detector import build_detector

def cpu():
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

saved = load_checkpoint(sys.argv[1])
model = build_detector(saved.config)
model.load_state_dict(saved.model)
start, wall = cpu(), time.perf_counter()
results = list(predict(model, saved.config, sys.argv[2], "val", torch.device("cpu"), progress=False))
inferred = cpu()
average_precisions(results, visible_objects(simgen.datasets.open(sys.argv[2]), [s for s, _ in results]))
detections = sum(len(d.scores) for _, d in results)
print(inferred - start, cpu() - inferred, time.perf_counter() - wall, len(results), detections)
"""


@dataclass(frozen=True)
class ValPass:
    """One val pass: CPU seconds of inference (loading included) and of AP, wall seconds of both, frames, detections."""

    inference_s: float
    ap_s: float
    wall_s: float
    frames: int
    detections: int


def val_pass(tree: Path, checkpoint: Path, dataset: Path) -> ValPass:
    """`tree`'s predict and AP on the val clips in a child process, one torch thread."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, "-c", VAL_PASS, str(checkpoint), str(dataset)],
        cwd=tree,
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    inference, ap, wall, frames, detections = done.stdout.split()
    return ValPass(float(inference), float(ap), float(wall), int(frames), int(detections))


def paper_rate(name: str, dataset: Path, iterations: int, device: torch.device) -> float:
    """Samples/s of a few steps of a paper-size config (after one warm-up step), loader in this process;
    on CPU at batch 2 (its batch of 8 needs more memory than a shared 2-core machine has to spare)."""
    raw = yaml.safe_load((ROOT / "train" / "configs" / "paper" / f"{name}.yaml").read_text())
    if device.type == "cpu":
        raw["train"]["batch_size"] = 2
    config = parse_config(raw)
    model = build_detector(config).to(device).train()
    samples = SampleSet(
        str(dataset), "train", config, draws=(iterations + 1) * config.train.batch_size, assign=model.head.assigner
    )
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.train.lr)
    batches = loader(samples, config.train.batch_size, 0, model.head.assigner.collate)
    for step in range(iterations + 1):
        if step == 1:
            start = time.perf_counter()
        batch = next(batches).to(device)
        with autocast(device, config.train.bf16):
            output = model(batch)
        terms = detection_loss(output.float(), batch.targets, config.loss)
        optimizer.zero_grad(set_to_none=True)
        terms.total.backward()
        optimizer.step()
    if device.type == "cuda":
        torch.cuda.synchronize()
    return iterations * config.train.batch_size / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="d2bfbe4", help="git revision to compare with (default d2bfbe4)")
    parser.add_argument("--iterations", type=int, default=40, help="fit iterations per measurement")
    parser.add_argument("--rounds", type=int, default=2, help="alternating fits per tree")
    parser.add_argument("--paper-iterations", type=int, default=3)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    devices = [torch.device("cpu")] + ([torch.device("cuda")] if torch.cuda.is_available() else [])
    with tempfile.TemporaryDirectory(prefix="bench_train-") as scratch:
        scratch = Path(scratch)
        trees = {"baseline": unpack(args.baseline, scratch / "baseline"), "this tree": ROOT}
        data, configs, rates = {}, {}, {name: [] for name in trees}
        for name, tree in trees.items():
            data[name] = scratch / f"paper_x1-{name.replace(' ', '_')}"
            child(tree, "simgen.cli", "generate", str(tree / "scenarios" / "paper_x1.yaml"), "-o", str(data[name]))
            runs = scratch / "runs" / name
            runs.mkdir(parents=True)
            configs[name] = compact_late(tree, args.iterations, runs)
        for round_ in range(args.rounds):
            for name, tree in trees.items():
                out = scratch / "runs" / name / f"fit{round_}"
                rates[name].append(fit_rate(tree, configs[name], data[name], out))
                print(f"{name}, round {round_}: {rates[name][-1]:.3f} samples/s", flush=True)
        checkpoints = {name: scratch / "runs" / name / "fit0" / "checkpoint.pt" for name in trees}
        val = {name: val_pass(tree, checkpoints[name], data[name]) for name, tree in trees.items()}
        breakdown = {d.type: step_breakdown(configs["this tree"], data["this tree"], 10, d) for d in devices}
        paper = {
            (m, d.type): paper_rate(m, data["this tree"], args.paper_iterations, d)
            for m in ("single", "late")
            for d in devices
        }
    median = {name: statistics.median(r) for name, r in rates.items()}
    fit_rows = [[name, args.iterations, " / ".join(f"{r:.3f}" for r in rates[name]), f"{median[name]:.3f}",
                 f"{median[name] / median['baseline']:.2f}"] for name in trees]
    total = {name: v.inference_s + v.ap_s for name, v in val.items()}
    val_rows = [
        [
            name,
            f"{v.inference_s:.2f}",
            f"{v.ap_s:.2f}",
            f"{total[name]:.2f}",
            f"{total[name] / total['baseline']:.3f}",
            f"{v.wall_s:.1f}",
            f"{v.detections / max(v.frames, 1):.0f}",
        ]
        for name, v in val.items()
    ]
    step_rows = [[phase] + [f"{1000 * breakdown[d.type][phase]:.0f}" for d in devices] for phase in breakdown["cpu"]]
    paper_rows = [[m] + [f"{paper[(m, d.type)]:.2f}" for d in devices] for m in ("single", "late")]
    write_results(
        "train",
        "Training speed (benchmarks/bench_train.py)",
        machine(torch=torch.__version__) + f" Baseline: revision {args.baseline}, same data, same work, alternating.",
        f"Compact late `fit` on paper_x1 (batch 2, one loader process, one torch thread), samples/s ({args.rounds} "
        f"rounds):",
        markdown_table(["tree", "iterations", "each round", "median", "ratio"], fit_rows),
        f"Val pass on the {val['this tree'].frames} val frames with each tree's checkpoint of the first round: "
        f"inference "
        "(loading included) and AP (visible boxes, AP of all and visible boxes at t, t-1, t-2), CPU seconds of a child "
        "process and its loader processes, one torch thread (imports and checkpoint loading not counted):",
        markdown_table(
            ["tree", "inference CPU s", "AP CPU s", "val pass CPU s", "ratio", "wall s", "detections per frame"],
            val_rows,
        ),
        "A step of this tree by phase, ms (compact late, batch 2; CUDA synchronised at each phase for this table "
        "only):",
        markdown_table(["phase"] + [d.type for d in devices], step_rows),
        f"Paper-size configs (train/configs/paper/), samples/s over {args.paper_iterations} steps after one warm-up, "
        "loader in this process; batch 2 on CPU, the configs' 8 on CUDA:",
        markdown_table(["model"] + [d.type for d in devices], paper_rows),
        out=args.out,
    )


if __name__ == "__main__":
    main()
