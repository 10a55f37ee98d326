"""Writing a dataset: `write_clip` once per clip (any process, any order), then `finish_dataset` once.

Clips never share a file (Parquet partitions by clip id, the KITTI-style formats number samples
by clip index), so clips can be written in parallel; `finish_dataset` then writes what needs them
all: the train/val ImageSets, the dataset card README.md and, last, manifest.json.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

from simgen import __version__
from simgen.datasets.card import dataset_card
from simgen.datasets.kitti import write_kitti_clip, write_placeholder_images
from simgen.datasets.manifest import FORMATS, MANIFEST_NAME, ClipEntry, Manifest, dependency_versions, manifest_bytes
from simgen.datasets.openpcdet import write_openpcdet_clip
from simgen.datasets.parquet import write_parquet_clip, write_parquet_sensors
from simgen.datasets.records import ClipRecord, FileRecord, write_bytes, write_text
from simgen.datasets.ros2_bag import write_mcap_clip
from simgen.datasets.samples import sample_name, val_clips
from simgen.datasets.schema import SCHEMA_VERSION
from simgen.errors import UserError
from simgen.vocab import TEAM_NAMES

if TYPE_CHECKING:
    from simgen.labels.labelled_frame import LabelledFrame
    from simgen.scan.sensor_info import SensorInfo

#: Clip ids become directory and file names: a leading letter, no '=' (not read as a hive partition).
CLIP_ID = re.compile(r"^[A-Za-z][A-Za-z0-9_.-]*$")
CARD_NAME = "README.md"
IMAGE_SET_FORMATS = ("kitti", "openpcdet")


def check_clip(format: str, frames: Sequence[LabelledFrame], clip_index: int) -> None:
    """One-line `UserError` for frames that do not make one whole clip, in order."""
    if format not in FORMATS:
        raise UserError(f"unknown dataset format {format!r} (choose from {', '.join(FORMATS)})")
    if not frames:
        raise UserError(f"clip index {clip_index}: no frames to write")
    clip = frames[0].clip
    if not CLIP_ID.match(clip):
        raise UserError(f"clip id {clip!r}: use a letter, then letters, digits, '_', '.' or '-'")
    if clip_index < 0:
        raise UserError(f"clip {clip}: clip index {clip_index} is negative")
    for position, frame in enumerate(frames):
        if frame.clip != clip or frame.index != position:
            raise UserError(
                f"clip {clip}: frame {position} is frame {frame.index} of clip {frame.clip}, expected the clip's frames in order from 0"
            )
        foreign = set(map(str, frame.labels.team)) - set(TEAM_NAMES)
        if foreign:
            raise UserError(f"clip {clip}, frame {position}: unknown team {sorted(foreign)[0]!r} (expected {', '.join(TEAM_NAMES)})")


def write_clip(
    root: Path, format: str, frames: Sequence[LabelledFrame], sensors: Sequence[SensorInfo], clip_index: int
) -> ClipRecord:
    """Write one clip's files under `root` (atomically, each); returns what `finish_dataset` needs."""
    check_clip(format, frames, clip_index)
    root = Path(root)
    if format == "parquet":
        files = write_parquet_clip(root, frames)
    elif format == "openpcdet":
        files = write_openpcdet_clip(root, frames, clip_index)
    elif format == "mcap":
        files = write_mcap_clip(root, frames, sensors)
    else:
        files = write_kitti_clip(root, frames, clip_index, tracking=format == "kitti_tracking")
    return ClipRecord(
        format=format,
        clip=frames[0].clip,
        clip_index=clip_index,
        frames=len(frames),
        points=sum(len(f.scan.points_m) for f in frames),
        boxes=sum(len(f.labels.boxes) for f in frames),
        files=tuple(sorted(files, key=lambda f: f.path)),
    )


def _image_sets(root: Path, clips: Sequence[ClipRecord]) -> list[FileRecord]:
    """ImageSets/{train,val,trainval}.txt: sample names, split by clip."""
    val = val_clips([c.clip_index for c in clips])
    names = {
        split: [sample_name(c.clip_index, i) for c in clips if (c.clip_index in val) == (split == "val") for i in range(c.frames)]
        for split in ("train", "val")
    }
    names["trainval"] = sorted(names["train"] + names["val"])
    return [write_text(root, f"ImageSets/{split}.txt", lines) for split, lines in names.items()]


def finish_dataset(
    root: Path, format: str, clips: Sequence[ClipRecord], sensors: Sequence[SensorInfo], scenario: Mapping, seed: int
) -> Manifest:
    """Write the ImageSets (KITTI, OpenPCDet) or the sensors table (Parquet), README.md and, last,
    manifest.json.

    KITTI with `scenario["dataset"]["kitti_images"]` also gets placeholder training/image_2 PNGs.
    """
    root = Path(root)
    clips = sorted(clips, key=lambda c: c.clip_index)
    if not clips:
        raise UserError(f"{root}: no clips written, nothing to finish")
    for kind, key in (("clip index", "clip_index"), ("clip id", "clip")):
        values = [getattr(c, key) for c in clips]
        if len(set(values)) != len(values):
            raise UserError(f"{root}: two clips have the same {kind}")
    if any(c.format != format for c in clips):
        raise UserError(f"{root}: clips written as {sorted({c.format for c in clips})}, finishing as {format}")
    files = [f for c in clips for f in c.files]
    if format in IMAGE_SET_FORMATS:
        files += _image_sets(root, clips)
    if format == "parquet":
        files.append(write_parquet_sensors(root, sensors))
    if format == "kitti" and scenario.get("dataset", {}).get("kitti_images"):
        files += write_placeholder_images(root, [(c.clip_index, c.frames) for c in clips])
    val = val_clips([c.clip_index for c in clips])
    manifest = Manifest(
        format=format,
        schema_version=SCHEMA_VERSION,
        simgen_version=__version__,
        dependencies=dependency_versions(),
        scenario=dict(scenario),
        seed=seed,
        sensors=tuple(asdict(s) for s in sorted(sensors, key=lambda s: s.sensor_id)),
        clips=tuple(
            ClipEntry(c.clip, c.clip_index, c.frames, c.points, c.boxes, "val" if c.clip_index in val else "train") for c in clips
        ),
        files=tuple(sorted(files, key=lambda f: f.path)),
    )
    write_card(root, manifest)  # first: a dataset whose manifest exists always has its card
    write_bytes(root, MANIFEST_NAME, manifest_bytes(manifest), len(manifest.files))
    return manifest


def write_card(root: Path, manifest: Manifest) -> None:
    """The dataset card, README.md, from the manifest."""
    write_bytes(Path(root), CARD_NAME, dataset_card(manifest).encode(), 0)
