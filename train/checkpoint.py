"""Checkpoints: the config and state dicts only, written atomically, read with weights_only=True."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from simgen.atomic import atomic_path
from simgen.errors import UserError
from train.config import DetectorConfig, parse_config

FORMAT = "simgen-train/detector"
VERSION = 2  # 2: the model config in named parts (pillar_encoder, backbone_2d, fusion, head)


@dataclass(frozen=True)
class Checkpoint:
    config: DetectorConfig
    model: dict[str, torch.Tensor]
    optimizer: dict[str, Any] | None
    iteration: int


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """torch.save under a temporary name beside `path`, then rename."""
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "config": checkpoint.config.model_dump(mode="json"),
        "model": checkpoint.model,
        "optimizer": checkpoint.optimizer,
        "iteration": checkpoint.iteration,
    }
    with atomic_path(path) as tmp:
        torch.save(payload, tmp)


def load_checkpoint(path: str | Path) -> Checkpoint:
    """Read a checkpoint that `simgen-train fit` wrote; anything else is a one-line `UserError`."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such checkpoint file")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # noqa: BLE001 - torch.load fails in many ways on a foreign file
        raise UserError(f"{path}: not a simgen-train checkpoint ({error.__class__.__name__})") from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise UserError(f"{path}: not a simgen-train detector checkpoint")
    if payload.get("version") != VERSION:
        raise UserError(f"{path}: checkpoint version {payload.get('version')!r}, this simgen-train reads {VERSION}")
    config = parse_config(payload.get("config"), f"{path} (config)")
    model, optimizer, iteration = payload.get("model"), payload.get("optimizer"), payload.get("iteration")
    if not isinstance(model, dict) or not all(
        isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in model.items()
    ):
        raise UserError(f"{path}: its 'model' is not a state dict of tensors")
    if not (optimizer is None or isinstance(optimizer, dict)) or type(iteration) is not int or iteration < 0:
        raise UserError(f"{path}: its 'optimizer' or 'iteration' is not what simgen-train writes")
    return Checkpoint(config, model, optimizer, iteration)
