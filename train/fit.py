"""Training: a seeded stream of augmented samples, AdamW on a one-cycle schedule, CSV log, checkpoints."""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from tqdm import tqdm

from train.checkpoint import Checkpoint, save_checkpoint
from train.config import DetectorConfig
from train.data import SampleSet, loader
from train.losses import detection_loss
from train.models.detector import build_detector

CHECKPOINT_NAME = "checkpoint.pt"
LOG_NAME = "train_log.csv"


def one_cycle_lr(step: int, total: int, peak: float) -> float:
    """OpenPCDet's Adam one-cycle: cosine from peak/10 up to peak over 40 % of the steps, then down to peak/1e4."""
    warm = max(int(0.4 * total), 1)
    if step < warm:
        low, high, phase = peak / 10, peak, step / warm
    else:
        low, high, phase = peak, peak / 1e4, (step - warm) / max(total - warm, 1)
    return high + (low - high) * 0.5 * (1 + math.cos(math.pi * phase))


@dataclass(frozen=True)
class FitResult:
    checkpoint: Path
    iterations: int
    samples_per_s: float  # training samples (frames t) per second of wall time, loading included


def fit(config: DetectorConfig, dataset: str, out: Path, device: torch.device, progress: bool = True) -> FitResult:
    """Train for `config.train.iterations` batches on the dataset's `train` clips; write into `out`."""
    train = config.train
    samples = SampleSet(dataset, "train", config, draws=train.iterations * train.batch_size)
    model = build_detector(config).to(device).train()
    optimizer = torch.optim.AdamW(model.parameters(), lr=train.lr, betas=(0.95, 0.99), weight_decay=train.weight_decay)
    out.mkdir(parents=True, exist_ok=True)
    fields = ["iteration", "seconds", "samples_per_s", "lr", "loss", "loss_cls", "loss_dir"]
    fields += [f"loss_loc_{k}" for k in range(config.model.tracklet_boxes)]

    def save(iteration: int) -> Path:
        path = out / CHECKPOINT_NAME
        save_checkpoint(path, Checkpoint(config, model.state_dict(), optimizer.state_dict(), iteration))
        return path

    start = time.perf_counter()
    with open(out / LOG_NAME, "w", newline="") as log_file:
        log = csv.DictWriter(log_file, fieldnames=fields)
        log.writeheader()
        bar = tqdm(loader(samples, train.batch_size, train.workers), total=train.iterations, desc=f"fit {config.name}",
                   unit="it", disable=not progress, dynamic_ncols=True)
        for step, batch in enumerate(bar):
            lr = one_cycle_lr(step, train.iterations, train.lr)
            for group in optimizer.param_groups:
                group["lr"] = lr
            batch = batch.to(device)
            terms = detection_loss(model(batch), batch, config.loss)
            optimizer.zero_grad(set_to_none=True)
            terms.total.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), train.grad_clip)
            optimizer.step()
            done = step + 1
            if done % train.log_every == 0 or done == train.iterations:
                values = terms.as_floats()
                seconds = time.perf_counter() - start
                log.writerow({"iteration": done, "seconds": f"{seconds:.2f}", "samples_per_s": f"{done * train.batch_size / seconds:.3f}",
                              "lr": f"{lr:.6g}", **{k: f"{v:.5f}" for k, v in values.items()}})
                log_file.flush()
                bar.set_postfix(loss=f"{values['loss']:.3f}", cls=f"{values['loss_cls']:.3f}")
            if done % train.checkpoint_every == 0 and done < train.iterations:
                save(done)
    seconds = time.perf_counter() - start
    return FitResult(save(train.iterations), train.iterations, train.iterations * train.batch_size / seconds)
