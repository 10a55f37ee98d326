"""`track --resume`: a run's state at its last completed chunk, in OUT's staging folder, so that a killed run goes on
from there and writes what an uninterrupted run writes, byte for byte.

Every CHUNK_FRAMES final frames of a clip, and at each clip's end, `state.npz` is replaced (written beside, then
renamed): the tracker's tracks, the ground truth's identities, the frame log's counts (its chunk files, with every
final frame's tracks, are already on disk), the frames the tracker holds back and the run's counters, with the
options it was run with (a resumed run must be given the same ones). Plain arrays only, read without pickle.

A resumed run rebuilds the interrupted clip's outputs (KITTI file, tracks table parts, MCAP bag) from the logged
tracks and the dataset's frames, then tracks on from the frame after the last one the state had seen.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from simgen.errors import UserError

STATE = "state.npz"


def save(staging: Path, meta: dict, arrays: dict[str, NDArray]) -> None:
    """Replace the run's state: `meta` (JSON) and plain arrays."""
    path, temporary = staging / STATE, staging / f".{STATE}.tmp"
    with open(temporary, "wb") as stream:
        np.savez(stream, meta=np.frombuffer(json.dumps(meta, sort_keys=True).encode(), np.uint8), **arrays)
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary, path)


def load(staging: Path, options: dict) -> tuple[dict, dict[str, NDArray]] | None:
    """The state an interrupted run left in `staging` (None: none), checked to be of the same `options`."""
    path = staging / STATE
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(arrays.pop("meta").tobytes())
    except (OSError, ValueError, KeyError):
        raise UserError(f"{path}: not a readable state of an interrupted run; run without --resume") from None
    if meta.get("options") != options:
        raise UserError(f"{staging.parent}: the interrupted run there had other options (dataset, detections, "
                        "tracker, split or filter); give the same ones, or run without --resume")
    return meta, arrays


def remove(staging: Path) -> None:
    (staging / STATE).unlink(missing_ok=True)
