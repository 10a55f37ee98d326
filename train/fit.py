"""Training: a seeded stream of augmented samples, AdamW on a one-cycle schedule, CSV log, learning curve, checkpoints.

On CUDA the loader pins its batches and the copies to the device overlap the model; the forward
pass runs under bfloat16 autocast (`train.bf16`), the loss in float32.
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import torch
from tqdm import tqdm

from train.accelerate import accelerate, wanted
from train.checkpoint import Checkpoint, save_checkpoint
from train.config import DetectorConfig
from train.data import SampleSet, loader
from train.detector.inference import predict
from train.detector.losses import LossTerms, detection_loss
from train.detector.model import Detector, build_detector
from train.evaluation.ap_table import average_precisions, mean_ap
from train.evaluation.learning_curve import CurvePoint, read_curve, write_curve
from train.preflight import check_resume
from train.run_folder import CHECKPOINT_NAME, LOG_NAME, RunFolder
from train.train_log import TrainLog, check_log, continued_log, log_fields, new_log


def one_cycle_lr(step: int, total: int, peak: float) -> float:
    """OpenPCDet's Adam one-cycle: cosine from peak/10 up to peak over 40 % of the steps, then down to peak/1e4."""
    warm = max(int(0.4 * total), 1)
    if step < warm:
        low, high, phase = peak / 10, peak, step / warm
    else:
        low, high, phase = peak, peak / 1e4, (step - warm) / max(total - warm, 1)
    return high + (low - high) * 0.5 * (1 + math.cos(math.pi * phase))


def autocast(device: torch.device, mode: str) -> contextlib.AbstractContextManager:
    """bfloat16 autocast for `train.bf16` (`auto`: on CUDA only; `on` works on CPU too, for tests)."""
    return torch.autocast(device.type, dtype=torch.bfloat16, enabled=wanted(mode, device))


def train_step(step_model: Callable, model: Detector, optimizer: torch.optim.Optimizer, batch, config: DetectorConfig,
               device: torch.device) -> LossTerms:
    """One optimiser step on a batch already on `device`: the forward pass of `step_model` (the model or its
    compiled wrapper, train.accelerate) under autocast, the float32 loss, backward, gradient clipping; its loss
    terms."""
    with autocast(device, config.train.bf16):
        output = step_model(batch)
    terms = detection_loss(output.float(), batch.targets, config.loss)
    optimizer.zero_grad(set_to_none=True)
    terms.total.backward()
    torch.nn.utils.clip_grad_norm_(model.parameters(), config.train.grad_clip)
    optimizer.step()
    return terms


@dataclass(frozen=True)
class FitResult:
    checkpoint: Path
    iterations: int  # done so far (fewer than the config's when stopped early)
    # training samples (frames t) per second of wall time in this run, loading included, val passes not
    samples_per_s: float
    stopped: bool = False  # by `stop_at` or `stop_after_s`: `fit(..., resume=True)` continues


def _val_point(
    model: Detector, config: DetectorConfig, dataset: str, device: torch.device, iteration: int
) -> CurvePoint:
    start = time.perf_counter()
    rows = average_precisions(list(predict(model, config, dataset, "val", device, progress=False)))
    model.train()
    return CurvePoint(iteration, rows, time.perf_counter() - start)


def fit(config: DetectorConfig, dataset: str, out: Path, device: torch.device, progress: bool = True, *,
        resume: bool = False, overwrite: bool = False, stop_at: int | None = None,
        stop_after_s: float | None = None) -> FitResult:
    """Train for `config.train.iterations` batches on the dataset's `train` clips; write into `out`.

    With `train.eval_every`, also score the val clips every that many iterations and after the
    last one (learning_curve.csv and .png); the weights do not depend on it. `resume`: continue the
    fit in `out` from its checkpoint (weights, optimiser, schedule, the stream of samples) and its log,
    to the same weights an uninterrupted fit reaches. `overwrite`: replace the run `out` holds (without
    either, a folder holding a run is refused: train.run_folder). `stop_at` (an iteration) or
    `stop_after_s` (seconds of this run): checkpoint there and stop, to be resumed.
    """
    train = config.train
    model = build_detector(config).to(device).train()
    optimizer = torch.optim.AdamW(model.parameters(), lr=train.lr, betas=(0.95, 0.99), weight_decay=train.weight_decay)
    fields = log_fields(config.model.head.tracklet_boxes)
    with RunFolder(out, resume, overwrite) as folder:
        first = 0
        if resume:
            saved = check_resume(out / CHECKPOINT_NAME, config)
            checked = check_log(out / LOG_NAME, fields, saved.iteration, saved.log_bytes, train.log_every)
            model.load_state_dict(saved.model)
            optimizer.load_state_dict(saved.optimizer)
            first = saved.iteration
        samples = SampleSet(dataset, "train", config, draws=train.iterations * train.batch_size,
                            assign=model.head.assigner, first_draw=first * train.batch_size)
        if train.eval_every:
            SampleSet(dataset, "val", config)  # no val clips: say so now, not after training
        folder.start()
        if resume:
            log, losses = continued_log(checked, fields), checked.losses
            if checked.torn:
                print(f"{out / LOG_NAME}: dropped its torn last row (written as the fit was killed)", file=sys.stderr)
        else:
            log, losses = new_log(out / LOG_NAME, fields), []
        try:
            return _train(model, optimizer, samples, config, dataset, out, device, progress, first, log, losses,
                          train.iterations if stop_at is None else min(train.iterations, stop_at), stop_after_s)
        finally:
            log.close()


def _train(model: Detector, optimizer: torch.optim.Optimizer, samples: SampleSet, config: DetectorConfig, dataset: str,
           out: Path, device: torch.device, progress: bool, first: int, log: TrainLog,
           losses: list[tuple[int, float]], last: int, stop_after_s: float | None) -> FitResult:
    """Iterations `first` + 1 to `last` (or fewer, out of time), logged, checkpointed every
    `train.checkpoint_every` and at the end, each checkpoint after the log rows it follows are on disk."""
    train, cuda = config.train, device.type == "cuda"
    step_model = accelerate(model, train, device)
    curve: list[CurvePoint] = read_curve(out, first) if first else []

    def save(iteration: int) -> Path:
        path, log_bytes = out / CHECKPOINT_NAME, log.sync()
        save_checkpoint(path, Checkpoint(config, model.state_dict(), optimizer.state_dict(), iteration, log_bytes))
        return path

    start, val_s, done = time.perf_counter(), 0.0, first
    batches = loader(samples, train.batch_size, train.workers, model.head.assigner.collate, pin_memory=cuda)
    bar = tqdm(batches, initial=first, total=train.iterations, desc=f"fit {config.name}", unit="it",
               disable=not progress, dynamic_ncols=True)
    for step, batch in enumerate(bar, start=first):
        lr = one_cycle_lr(step, train.iterations, train.lr)
        for group in optimizer.param_groups:
            group["lr"] = lr
        terms = train_step(step_model, model, optimizer, batch.to(device, non_blocking=cuda), config, device)
        done = step + 1
        if done % train.log_every == 0 or done == train.iterations:
            values = terms.as_floats()
            losses.append((done, values["loss"]))
            seconds = time.perf_counter() - start
            log.append({"iteration": done, "seconds": f"{seconds:.2f}",
                        "samples_per_s": f"{(done - first) * train.batch_size / (seconds - val_s):.3f}",
                        "lr": f"{lr:.6g}", **{k: f"{v:.5f}" for k, v in values.items()}})
            bar.set_postfix(loss=f"{values['loss']:.3f}", cls=f"{values['loss_cls']:.3f}")
        if train.eval_every and (done % train.eval_every == 0 or done == train.iterations):
            curve.append(_val_point(model, config, dataset, device, done))
            val_s += curve[-1].eval_s
            write_curve(out, curve, losses, f"{config.name}: AP on val while training")
            bar.set_postfix(loss=f"{terms.as_floats()['loss']:.3f}", ap3d=f"{mean_ap(curve[-1].rows, '3d'):.1f}")
        out_of_time = stop_after_s is not None and time.perf_counter() - start >= stop_after_s
        if done == last or out_of_time:
            break
        if done % train.checkpoint_every == 0:
            save(done)
    seconds = time.perf_counter() - start - val_s
    return FitResult(save(done), done, (done - first) * train.batch_size / max(seconds, 1e-9), done < train.iterations)
