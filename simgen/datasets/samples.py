"""What the KITTI-style formats (KITTI, OpenPCDet custom) share: sample numbers, x-y-z-intensity
arrays, number text and the train/val split.

Sample numbers are global and fixed by (clip index, frame index) alone, so clips written in
parallel never collide: number = clip_index * MAX_FRAMES_PER_CLIP + frame index, written with
at least 6 digits (`000000`, ..., `010003` is frame 3 of clip index 1).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.formats import MAX_FRAMES_PER_CLIP
from simgen.datasets.records import FileRecord, write_text
from simgen.errors import UserError

if TYPE_CHECKING:
    from simgen.datasets.records import ClipRecord

INTENSITY_SCALE = 255.0  # stored intensity = reflectivity / 255, in [0, 1] as KITTI's
VAL_FRACTION = 0.2  # of the clips (the last ones), when there are two or more
IMAGE_SETS = ("ImageSets/train.txt", "ImageSets/val.txt", "ImageSets/trainval.txt")


def sample_number(clip_index: int, index: int) -> int:
    if not 0 <= index < MAX_FRAMES_PER_CLIP:
        raise UserError(f"frame index {index}: KITTI-style formats hold at most {MAX_FRAMES_PER_CLIP} frames per clip")
    return clip_index * MAX_FRAMES_PER_CLIP + index


def sample_name(clip_index: int, index: int) -> str:
    return f"{sample_number(clip_index, index):06d}"


def to_xyzi(points_m: NDArray[np.float32], intensity: NDArray[np.uint8]) -> NDArray[np.float32]:
    """(P, 4) float32: x, y, z (metres, pitch frame), intensity / 255."""
    scaled = (intensity.astype(np.float32) / np.float32(INTENSITY_SCALE))[:, None]
    return np.ascontiguousarray(np.concatenate([points_m.astype(np.float32), scaled], axis=1))


def from_xyzi(xyzi: NDArray[np.float32]) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    """Inverse of `to_xyzi`, exact: points (P, 3) and intensity (P,) 0-255."""
    intensity = np.rint(xyzi[:, 3].astype(np.float64) * INTENSITY_SCALE).astype(np.uint8)
    return np.ascontiguousarray(xyzi[:, :3]), intensity


def float32_text(value: float) -> str:
    """Shortest decimal that reads back as the same float32."""
    return np.format_float_positional(np.float32(value), unique=True, trim="-")


def float64_text(value: float) -> str:
    """Shortest decimal that reads back as the same float64."""
    return repr(float(value))


def val_clips(clip_indices: Sequence[int]) -> set[int]:
    """The clips of the validation split: the last VAL_FRACTION of them (at least one of two or more)."""
    ordered = sorted(clip_indices)
    if len(ordered) < 2:
        return set()
    return set(ordered[-max(1, round(VAL_FRACTION * len(ordered))) :])


def val_frames(frames: int) -> int:
    """Frames of a dataset's one clip in the ImageSets' val split: its last VAL_FRACTION (at least one of two or
    more), so that OpenPCDet's evaluation, which indexes the first val sample, has one."""
    return max(1, round(VAL_FRACTION * frames)) if frames > 1 else 0


def split_samples(clips: Sequence[ClipRecord]) -> dict[str, list[str]]:
    """Sample names of the `train` and `val` splits: by clip (one clip: its last `val_frames` are val)."""
    val = val_clips([c.clip_index for c in clips])
    samples = [(c.clip_index in val, sample_name(c.clip_index, i)) for c in clips for i in range(c.frames)]
    if len(clips) == 1:
        first_val = clips[0].frames - val_frames(clips[0].frames)
        samples = [(i >= first_val, name) for i, (_, name) in enumerate(samples)]
    return {split: [name for in_val, name in samples if in_val == (split == "val")] for split in ("train", "val")}


def write_image_sets(root: Path, clips: Sequence[ClipRecord]) -> list[FileRecord]:
    """IMAGE_SETS, train.txt, val.txt and trainval.txt: the sample names of `split_samples`."""
    names = split_samples(clips)
    names["trainval"] = sorted(names["train"] + names["val"])
    return [write_text(root, f"ImageSets/{split}.txt", lines) for split, lines in names.items()]
