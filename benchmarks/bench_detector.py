"""Training samples per second and inference frames per second of the three detectors, on CPU.

Each rate is also given as a ratio to two baselines measured in the same run: the bare loading
(reading three frames through simgen.datasets, cropping, pillar indices and anchor targets, in
this process) and the `single` model. Data: a 12-frame clip of the paper's x1 scenario,
generated into a temporary folder. Training: the config's batch, loader in this process (workers
0), after one warm-up step; inference: one frame per call, decoding and NMS included.

Usage: .venv/bin/python benchmarks/bench_detector.py [--out benchmarks/results/detector.md] [--steps 20] [--frames 30]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch
from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from train.config import load_config
from train.data import SampleSet, collate, loader
from train.detector.losses import detection_loss
from train.detector.model import build_detector
from train.detector.postprocess import postprocess

MODELS = ("single", "early", "late")


def make_dataset(folder: Path) -> str:
    out = folder / "paper_x1_12"
    command = [
        sys.executable,
        "-m",
        "simgen.cli",
        "generate",
        str(ROOT / "scenarios" / "paper_x1.yaml"),
        "-o",
        str(out),
        "--frames",
        "12",
        "--clips",
        "1",
    ]
    subprocess.run(command, check=True, capture_output=True, cwd=ROOT)
    return str(out)


def loading_rate(dataset: str, samples: int) -> float:
    """Samples/s of reading and encoding alone (the `late` inputs: three frames)."""
    config = load_config(ROOT / "train" / "configs" / "late.yaml")
    data = SampleSet(dataset, None, config, assign=build_detector(config).head.assigner)
    data[0]
    start = time.perf_counter()
    for i in range(samples):
        data[i % len(data)]
    return samples / (time.perf_counter() - start)


def training_rate(name: str, dataset: str, steps: int) -> float:
    config = load_config(ROOT / "train" / "configs" / f"{name}.yaml")
    batch = config.train.batch_size
    model = build_detector(config).train()
    data = SampleSet(dataset, None, config, draws=(steps + 1) * batch, assign=model.head.assigner)
    optimizer = torch.optim.AdamW(model.parameters(), lr=config.train.lr)
    batches = loader(data, batch, 0, model.head.assigner.collate)

    def step() -> None:
        b = next(batches)
        loss = detection_loss(model(b), b.targets, config.loss).total
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()

    step()
    start = time.perf_counter()
    for _ in range(steps):
        step()
    return steps * batch / (time.perf_counter() - start)


def inference_rate(name: str, dataset: str, frames: int) -> float:
    config = load_config(ROOT / "train" / "configs" / f"{name}.yaml")
    data = SampleSet(dataset, None, config)
    rows, cols = config.data.grid_size
    model = build_detector(config).eval()

    def one(i: int) -> None:
        batch = collate([data[i % len(data)]], config.model.fusion.canvases, rows * cols)
        postprocess(model(batch), model.head.anchors, config)

    with torch.no_grad():
        one(0)
        start = time.perf_counter()
        for i in range(frames):
            one(i)
    return frames / (time.perf_counter() - start)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/detector.md)")
    parser.add_argument("--steps", type=int, default=20, help="timed training steps per model")
    parser.add_argument("--frames", type=int, default=30, help="timed inference frames per model")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        dataset = make_dataset(Path(folder))
        loading = loading_rate(dataset, 2 * args.frames)
        rates = {m: (training_rate(m, dataset, args.steps), inference_rate(m, dataset, args.frames)) for m in MODELS}
    single_train, single_infer = rates["single"]
    rows = [
        [name, f"{train:.2f}", f"{train / loading:.3f}", f"{train / single_train:.2f}", f"{infer:.2f}",
         f"{infer / loading:.3f}", f"{infer / single_infer:.2f}"]
        for name, (train, infer) in rates.items()
    ]
    write_results(
        "detector",
        "Detector throughput on CPU",
        f"Written by `benchmarks/bench_detector.py --steps {args.steps} --frames {args.frames}`; "
        f"{torch.get_num_threads()} torch threads. " + machine(torch=torch.__version__),
        "Configs as committed (train/configs/): the paper's range [-40, 40] x [-40, 40] x [-0.1, 2.5] m, 0.25 m "
        "pillars "
        "(320 x 320), backbone 4/6/6 layers of 8/16/32 channels, output 160 x 160 x 2 anchors. Data: one 12-frame clip "
        "of scenarios/paper_x1.yaml. Baseline `loading`: reading three frames through simgen.datasets, crop, pillar "
        f"indices and anchor targets in one process: {loading:.2f} samples/s.",
        markdown_table(
            ["model", "train samples/s", "vs loading", "vs single", "inference frames/s", "vs loading", "vs single"],
            rows,
        ),
        out=args.out,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
