"""Training speed on a GPU: the paper-size step's samples/s under each speed choice of train.accelerate, each
change measured in the same run right after the step before it.

The variants add up in order (each keeps the ones before it):
  base           bfloat16 autocast alone (the step as it trained on the H100 on 2026-11-26)
  cudnn          + cuDNN's algorithm search (`train.cudnn_benchmark`)
  channels_last  + (N, H, W, C) weights and maps (`train.channels_last`)
  compile        + torch.compile of the detector (`train.compile`; its compile time reported apart)

Each variant: the model built from the config's seed, AdamW, the real training batches of the dataset
(BATCHES of them, read once by the project's loader and kept on the GPU, so the loader cannot limit the
step), WARM-UP steps, then STEPS timed steps (forward under autocast, float32 loss, backward, gradient
clipping, optimiser), synchronised at the ends only. Peak GPU memory per variant.

Needs CUDA (`--device cpu` only tries the script). Usage (from the repository root):
  python benchmarks/bench_train_cuda.py --dataset D [--models late,single] [--variants base,cudnn,channels_last]
      [--steps 40] [--warm-up 5] [--batches 8] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch
from table import machine, markdown_table, write_results

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from train.accelerate import accelerate
from train.config import load_config
from train.data import SampleSet, loader
from train.detector.model import build_detector
from train.fit import train_step

VARIANTS = {  # the speed choices each variant turns on, cumulative
    "base": {"cudnn_benchmark": "off", "channels_last": "off", "compile": "off"},
    "cudnn": {"cudnn_benchmark": "on", "channels_last": "off", "compile": "off"},
    "channels_last": {"cudnn_benchmark": "on", "channels_last": "on", "compile": "off"},
    "compile": {"cudnn_benchmark": "on", "channels_last": "on", "compile": "on"},
}


def measure(config_path: Path, variant: str, dataset: str, batches: int, warm_up: int, steps: int,
            device: torch.device) -> dict[str, float]:
    """samples/s, warm-up seconds and peak GiB of `steps` training steps of a config under `variant`."""
    config = load_config(config_path)
    config = config.model_copy(update={"train": config.train.model_copy(update=VARIANTS[variant])})
    train = config.train
    model = build_detector(config).to(device).train()
    step_model = accelerate(model, train, device)
    optimizer = torch.optim.AdamW(model.parameters(), lr=1e-4, betas=(0.95, 0.99), weight_decay=train.weight_decay)
    samples = SampleSet(dataset, "train", config, draws=batches * train.batch_size, assign=model.head.assigner)
    kept = [b.to(device) for b in loader(samples, train.batch_size, 4, model.head.assigner.collate, pin_memory=True)]
    cuda = device.type == "cuda"
    sync = torch.cuda.synchronize if cuda else (lambda _: None)
    if cuda:
        torch.cuda.reset_peak_memory_stats(device)

    def step(batch) -> None:
        train_step(step_model, model, optimizer, batch, config, device)

    sync(device)
    start = time.perf_counter()
    for k in range(warm_up):
        step(kept[k % len(kept)])
    sync(device)
    warmed = time.perf_counter()
    for k in range(steps):
        step(kept[(warm_up + k) % len(kept)])
    sync(device)
    seconds = time.perf_counter() - warmed
    return {"samples_per_s": steps * train.batch_size / seconds, "warm_up_s": warmed - start,
            "peak_gib": torch.cuda.max_memory_allocated(device) / 2**30 if cuda else float("nan")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, help="a Parquet dataset with train clips")
    parser.add_argument("--models", default="late,single", help="configs in --configs, comma-separated")
    parser.add_argument("--configs", type=Path, default=ROOT / "train" / "configs" / "paper")
    parser.add_argument("--device", default="cuda", help="cuda; cpu only to try the script with small configs")
    parser.add_argument("--variants", default="base,cudnn,channels_last", help=f"of {', '.join(VARIANTS)}")
    parser.add_argument("--steps", type=int, default=40, help="timed steps per variant")
    parser.add_argument("--warm-up", type=int, default=5, help="untimed steps first (compile: at least 3)")
    parser.add_argument("--batches", type=int, default=8, help="distinct training batches cycled")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    device = torch.device(args.device)
    if device.type == "cuda" and not torch.cuda.is_available():
        sys.exit("bench_train_cuda: needs a CUDA device")
    rows = []
    for model_name in args.models.split(","):
        base = None
        for variant in args.variants.split(","):
            result = measure(args.configs / f"{model_name}.yaml", variant, args.dataset, args.batches, args.warm_up,
                             args.steps, device)
            base = base or result["samples_per_s"]
            rows.append([model_name, variant, f"{result['samples_per_s']:.1f}", f"{result['samples_per_s'] / base:.2f}",
                         f"{result['warm_up_s']:.1f}", f"{result['peak_gib']:.1f}"])
            print(" | ".join(rows[-1]), flush=True)
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "cpu"
    write_results(
        "train_cuda",
        "Paper-size training step on a GPU (benchmarks/bench_train_cuda.py)",
        machine(torch=torch.__version__) + f" Device: {name}.",
        f"Configs {args.configs.relative_to(ROOT) if args.configs.is_relative_to(ROOT) else args.configs}, "
        f"their batch size, {args.batches} real training batches of {args.dataset} kept on the GPU, "
        f"{args.warm_up} warm-up steps, then {args.steps} timed steps; each variant adds its choice to the ones "
        "above it; ratio against base in the same run:",
        markdown_table(["model", "variant", "samples/s", "ratio", "warm-up s", "peak GiB"], rows, left=2),
        out=args.out,
    )


if __name__ == "__main__":
    main()
