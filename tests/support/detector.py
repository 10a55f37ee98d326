"""Shared by the detector tests: a small real dataset (simgen generate, smoke scenario) and tiny configs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.support import ROOT
from train.config import DetectorConfig, parse_config

SMOKE = ROOT / "scenarios" / "smoke.yaml"
# The touchline sensor's side of the centre circle: 128 x 128 pillars, ~10 players.
TINY_RANGE_M = [-16.0, -24.0, -0.1, 16.0, 8.0, 2.5]
_made: dict[int, Path] = {}


def smoke_dataset(root: Path, frames: int) -> Path:
    """`simgen generate scenarios/smoke.yaml --frames N` once per test session and frame count."""
    if frames not in _made:
        out = root / f"smoke_{frames}"
        command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out), "--frames", str(frames)]
        subprocess.run(command, check=True, capture_output=True, cwd=ROOT, timeout=300)
        _made[frames] = out
    return _made[frames]


def tiny_config(fusion: str, channels: int = 8, **train: object) -> DetectorConfig:
    """A CPU-light detector for a method (single, early, late): small grid, one-layer blocks of `channels`
    (then twice that), no augmentation."""
    return parse_config(
        {
            "name": f"tiny_{fusion}",
            "data": {
                "point_range_m": TINY_RANGE_M,
                "augment": {"rotation_rad": 0.0, "flip_x": False, "scale": [1.0, 1.0]},
            },
            "model": {
                "pillar_encoder": {"channels": channels},
                "backbone_2d": {
                    "layers": [1, 2, 2],
                    "channels": [channels, channels, 2 * channels],
                    "upsample_channels": [channels] * 3,
                },
                "fusion": {"name": fusion},
                "head": {"tracklet_boxes": 3 if fusion == "late" else 1},
            },
            "train": {"workers": 0, "log_every": 1, **train},
        }
    )
