"""Checkpoints: the config and state dicts only, written atomically and made durable (fsync), checked
against their zip's CRC-32s before torch reads them, read with weights_only=True."""

from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from simgen.atomic import atomic_path
from simgen.errors import UserError
from train.config import DetectorConfig, parse_config

FORMAT = "simgen-train/detector"
VERSION = 2  # 2: the model config in named parts (pillar_encoder, backbone_2d, fusion, head)
DOS_FOLDER = 0x10  # a zip member's MS-DOS "directory" attribute: torch's reader then reads no bytes of it


@dataclass(frozen=True)
class Checkpoint:
    config: DetectorConfig
    model: dict[str, torch.Tensor]
    optimizer: dict[str, Any] | None
    iteration: int
    log_bytes: int | None = None  # train_log.csv's length when saved: its rows up to `iteration` (None: not known)


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """torch.save under a temporary name beside `path`, on disk (fsync) before it is renamed, and the rename
    on disk before this returns."""
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "config": checkpoint.config.model_dump(mode="json"),
        "model": checkpoint.model,
        "optimizer": checkpoint.optimizer,
        "iteration": checkpoint.iteration,
        "log_bytes": checkpoint.log_bytes,
    }
    with atomic_path(path) as tmp, open(tmp, "wb") as file:
        torch.save(payload, file)
        file.flush()
        os.fsync(file.fileno())
    sync_folder(path.parent)


def sync_folder(folder: Path) -> None:
    """fsync a folder: the renames and new names in it are on disk."""
    descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _check_archive(path: Path) -> None:
    """A one-line `UserError` unless `path` is a zip as torch.save writes it (every member a file, stored, not
    compressed, so none is larger than the file) whose members all match their CRC-32."""
    with open(path, "rb") as file:
        start = file.read(4)
    if start != b"PK\x03\x04":  # a zip's first local header
        raise UserError(f"{path}: not a simgen-train checkpoint (not the zip archive torch.save writes)")
    try:
        with zipfile.ZipFile(path) as archive:
            packed = [m.filename for m in archive.infolist() if m.compress_type != zipfile.ZIP_STORED]
            if packed:
                raise UserError(f"{path}: not a simgen-train checkpoint (compressed member {packed[0][:60]!r})")
            folders = [m.filename for m in archive.infolist() if m.is_dir() or m.external_attr & DOS_FOLDER]
            failed = folders[0] if folders else archive.testzip()
    except (zipfile.BadZipFile, NotImplementedError, ValueError, EOFError, OSError) as error:  # its offsets too
        raise UserError(f"{path}: a damaged checkpoint (its zip: {str(error)[:80]!r})") from None
    if failed is not None:
        raise UserError(f"{path}: a damaged checkpoint (its member {failed[:60]!r} fails its CRC-32 check or is "
                        "marked a folder)")


def load_checkpoint(path: str | Path) -> Checkpoint:
    """Read a checkpoint that `simgen-train fit` wrote; anything else is a one-line `UserError`."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a folder, not a checkpoint file")
    if not path.exists():
        raise UserError(f"{path}: no such checkpoint file")
    if not path.is_file():
        raise UserError(f"{path}: not a regular file, not a checkpoint")
    _check_archive(path)
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
    log_bytes = payload.get("log_bytes")  # absent from checkpoints written before it was recorded
    if not (log_bytes is None or (type(log_bytes) is int and log_bytes >= 0)):
        raise UserError(f"{path}: its 'log_bytes' is not what simgen-train writes")
    return Checkpoint(config, model, optimizer, iteration, log_bytes)
