"""Training and evaluation samples: three consecutive frames read through simgen.datasets.

A sample at frame t holds the point clouds the model reads (t alone for `single`; t-2, t-1, t
otherwise) and, for every object of the configured classes whose centre at t is in range, its
boxes at t-2, t-1 and t matched by track id. Augmentation (flip, rotation, scale) is one global
transform for all three frames; the crop follows it. Points become pillar indices here, in the
loader's workers; the model turns them into pillar features. Training targets come from the
detector's own target assigner (train.detector.target_assigner), handed in by the caller, so this
module knows nothing of anchors or models.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

import simgen.datasets
from simgen.errors import UserError
from train.config import TRACKLET_FRAMES, AugmentConfig, DetectorConfig
from train.parent_death import die_with_parent

Assign = Callable[[NDArray[np.float32], NDArray[np.bool_]], Any]  # (boxes (G, 3, 7), box_mask (G, 3)) -> targets


@dataclass(frozen=True)
class Sample:
    """Frame t of a clip with the frames before it; pitch frame, metres, radians."""

    clip: str
    index: int  # frame t
    points: tuple[NDArray[np.float32], ...]  # per input frame, oldest first: (P, 4) x, y, z, intensity
    boxes: NDArray[np.float32]  # (G, 3, 7) each object's boxes at t-2, t-1, t
    box_mask: NDArray[np.bool_]  # (G, 3) False where the track has no label at that frame, or one before a placement
    track_id: NDArray[np.int64]  # (G,)
    placed: NDArray[np.bool_]  # (G,) the box at t has a discontinuity: the engine placed the humanoid since t-1


def sample_keys(dataset: simgen.datasets.Dataset, split: str | None, protocol: str = "clip") -> list[tuple[str, int]]:
    """(clip, t) for every frame t with two before it in `split` (None: all), by `protocol`:

    - `clip`: the windows of the clips the dataset puts in that split;
    - `frame`: every k-th window of each clip is `val`, k chosen so that val holds about as many frames
      as one clip (three per window), and `train` is every window that shares no frame with a val one
      (so the nearest training frame is one frame, ~0.1 s, from a val frame: as near as a random split
      of frames puts them).
    """
    if protocol == "clip":
        clips = [c for c in dataset.clips if split is None or dataset.split(c) == split]
        if not clips:
            raise UserError(f"{dataset.root}: no clips in the {split!r} split")
        return [(clip, t) for clip in clips for t in range(TRACKLET_FRAMES - 1, dataset.num_frames(clip))]
    windows = {c: list(range(TRACKLET_FRAMES - 1, dataset.num_frames(c))) for c in dataset.clips}
    clip_frames = round(np.mean([dataset.num_frames(c) for c in dataset.clips]))
    every = max(2 * TRACKLET_FRAMES, round(TRACKLET_FRAMES * sum(map(len, windows.values())) / max(clip_frames, 1)))
    val = {c: [t for t in ts if (t - TRACKLET_FRAMES + 1) % every == every // 2] for c, ts in windows.items()}
    if split is None:
        return [(c, t) for c, ts in windows.items() for t in ts]
    if split == "val":
        return [(c, t) for c, ts in val.items() for t in ts]
    apart = {c: [t for t in ts if all(abs(t - v) >= TRACKLET_FRAMES for v in val[c])] for c, ts in windows.items()}
    return [(c, t) for c, ts in apart.items() for t in ts]


def _discontinuity(frame: simgen.datasets.Frame) -> NDArray[np.bool_]:
    return np.zeros(len(frame.boxes), bool) if frame.discontinuity is None else frame.discontinuity


def frame_points(frame: simgen.datasets.Frame) -> NDArray[np.float32]:
    """(P, 4) x, y, z and intensity / 255 of a frame's points, as the model reads them."""
    return np.column_stack([frame.points_m, frame.intensity.astype(np.float32) / 255.0]).astype(np.float32)


def load_sample(
    dataset: simgen.datasets.Dataset | RecentFrames, clip: str, index: int, config: DetectorConfig
) -> Sample:
    """Read frames t-2..t and match the boxes of the objects at t by track id. Where the engine placed
    an object for a restart within the window (a box's discontinuity flag), its boxes before the
    placement are masked: they belong to another segment of its motion."""
    frames = dataset.sequence(clip, index, TRACKLET_FRAMES)
    if any(f.track_id is None for f in frames):
        raise UserError(
            f"{dataset.root}: the detector needs track ids (write the dataset as parquet or kitti_tracking)"
        )
    last = frames[-1]
    keep = np.isin(last.class_name, config.data.classes)
    track_id = last.track_id[keep].astype(np.int64)
    boxes = np.repeat(last.boxes[keep][:, None], TRACKLET_FRAMES, axis=1)
    mask = np.ones((len(track_id), TRACKLET_FRAMES), bool)
    placed = np.zeros((len(track_id), TRACKLET_FRAMES), bool)
    placed[:, -1] = _discontinuity(last)[keep]
    for k, frame in enumerate(frames[:-1]):
        order = np.argsort(frame.track_id)
        at = np.searchsorted(frame.track_id, track_id, sorter=order).clip(0, max(len(order) - 1, 0))
        found = (frame.track_id[order[at]] == track_id) if len(order) else np.zeros(len(track_id), bool)
        boxes[found, k] = frame.boxes[order[at[found]]]
        placed[found, k] = _discontinuity(frame)[order[at[found]]]
        mask[:, k] = found
    for k in range(1, TRACKLET_FRAMES):
        mask[placed[:, k], :k] = False
    points = tuple(frame_points(f) for f in frames[-config.model.fusion.input_frames:])
    return Sample(clip, index, points, boxes.astype(np.float32), mask, track_id, placed[:, -1])


def augment(sample: Sample, config: AugmentConfig, rng: np.random.Generator) -> Sample:
    """One random flip (x -> -x), rotation about z and scale, applied to every frame and box."""
    flip = config.flip_x and rng.random() < 0.5
    angle = rng.uniform(-config.rotation_rad, config.rotation_rad)
    scale = rng.uniform(*config.scale)
    cos, sin = math.cos(angle), math.sin(angle)
    turn = np.array([[cos, -sin], [sin, cos]], np.float32)

    def move(xyz: NDArray[np.float32]) -> NDArray[np.float32]:
        out = xyz.copy()
        if flip:
            out[..., 0] = -out[..., 0]
        out[..., :2] = out[..., :2] @ turn.T
        return out * np.float32(scale)

    points = tuple(np.concatenate([move(p[:, :3]), p[:, 3:]], axis=1) for p in sample.points)
    boxes = sample.boxes.copy()
    boxes[..., :3] = move(boxes[..., :3])
    boxes[..., 3:6] *= np.float32(scale)
    yaw = np.pi - boxes[..., 6] if flip else boxes[..., 6]
    boxes[..., 6] = np.mod(yaw + angle + np.pi, 2 * np.pi) - np.pi
    return replace(sample, points=points, boxes=boxes)


def crop(sample: Sample, point_range_m: tuple[float, ...]) -> Sample:
    """Points inside the range (upper bounds excluded) and objects whose centre at t is inside in x, y."""
    low, high = np.asarray(point_range_m[:3], np.float32), np.asarray(point_range_m[3:], np.float32)

    def inside_range(p: NDArray[np.float32]) -> NDArray[np.bool_]:
        inside = (p[:, 0] >= low[0]) & (p[:, 0] < high[0])
        for axis in (1, 2):
            inside &= (p[:, axis] >= low[axis]) & (p[:, axis] < high[axis])
        return inside

    points = tuple(p[inside_range(p)] for p in sample.points)
    centre = sample.boxes[:, -1, :2]
    inside = np.all((centre >= low[:2]) & (centre < high[:2]), axis=1)
    return replace(sample, points=points, boxes=sample.boxes[inside], box_mask=sample.box_mask[inside],
                   track_id=sample.track_id[inside], placed=sample.placed[inside])


def model_points(sample: Sample, config: DetectorConfig) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """Point features (P, F) and each point's canvas (P,): early fusion merges the sweeps with a time channel."""
    if not config.model.fusion.time_channel:
        canvas = np.concatenate([np.full(len(p), k, np.int64) for k, p in enumerate(sample.points)])
        return np.concatenate(sample.points), canvas
    offsets = np.arange(1 - len(sample.points), 1, dtype=np.float32)  # frames before t: -2, -1, 0
    merged = [np.column_stack([p, np.full(len(p), dt, np.float32)]) for p, dt in zip(sample.points, offsets)]
    return np.concatenate(merged), np.zeros(sum(len(p) for p in merged), np.int64)


def pillar_cells(xyz_m: NDArray[np.float32], config: DetectorConfig) -> NDArray[np.int64]:
    """(P,) flat index row * columns + column of each (cropped) point's pillar."""
    rows, cols = config.data.grid_size
    x0, y0 = config.data.point_range_m[:2]
    size = config.data.pillar_size_m
    col = np.floor((xyz_m[:, 0] - x0) / size).astype(np.int64).clip(0, cols - 1)
    row = np.floor((xyz_m[:, 1] - y0) / size).astype(np.int64).clip(0, rows - 1)
    return row * cols + col


@dataclass(frozen=True)
class Encoded:
    """A sample as the model and loss read it (numpy, one sample)."""

    sample: Sample  # after augmentation and crop
    features: NDArray[np.float32]  # (P, F)
    cells: NDArray[np.int64]  # (P,) flat pillar index within the point's canvas
    canvas: NDArray[np.int64]  # (P,) which input canvas (frame) the point belongs to
    targets: Any  # what the detector's assigner made of the sample's boxes; None when not training


def encode_sample(sample: Sample, config: DetectorConfig, assign: Assign | None = None) -> Encoded:
    features, canvas = model_points(sample, config)
    targets = None if assign is None else assign(sample.boxes, sample.box_mask)
    return Encoded(sample, features, pillar_cells(features[:, :3], config), canvas, targets)


@dataclass(frozen=True)
class Batch:
    """Samples collated for the model: torch tensors, points of all samples concatenated."""

    features: torch.Tensor  # (P, F) float32
    pillar: torch.Tensor  # (U,) int64 the non-empty pillars, sorted flat indices into (B * canvases * rows * columns)
    point_pillar: torch.Tensor  # (P,) int64 each point's pillar, 0 .. U - 1
    batch_size: int
    targets: Any  # the assigner's collated targets (train.detector.target_assigner.BatchTargets), or None
    samples: tuple[Sample, ...]

    def to(self, device: torch.device, non_blocking: bool = False) -> Batch:
        targets = None if self.targets is None else self.targets.to(device, non_blocking=non_blocking)
        return replace(self, features=self.features.to(device, non_blocking=non_blocking),
                       pillar=self.pillar.to(device, non_blocking=non_blocking),
                       point_pillar=self.point_pillar.to(device, non_blocking=non_blocking), targets=targets)

    def pin_memory(self) -> Batch:
        """Page-locked copies, for asynchronous copies to a CUDA device (DataLoader(pin_memory=True) calls it)."""
        targets = None if self.targets is None else self.targets.pin_memory()
        return replace(self, features=self.features.pin_memory(), pillar=self.pillar.pin_memory(),
                       point_pillar=self.point_pillar.pin_memory(), targets=targets)


def collate(
    items: list[Encoded], canvases: int, grid_cells: int, collate_targets: Callable[[list], Any] | None = None
) -> Batch:
    """Concatenate samples and group their points into pillars (indices with per-sample offsets, here in
    the loader's workers rather than on the model's device); targets go to `collate_targets`."""
    cells = np.concatenate([(b * canvases + e.canvas) * grid_cells + e.cells for b, e in enumerate(items)])
    pillar, point_pillar = np.unique(cells, return_inverse=True)
    return Batch(
        features=torch.from_numpy(np.concatenate([e.features for e in items])),
        pillar=torch.from_numpy(pillar),
        point_pillar=torch.from_numpy(point_pillar.reshape(-1)),
        batch_size=len(items),
        targets=None if collate_targets is None else collate_targets([e.targets for e in items]),
        samples=tuple(e.sample for e in items),
    )


class RecentFrames:
    """A dataset read through a memory of the last window's frames: windows taken in clip order (evaluation)
    read each frame once, not three times."""

    def __init__(self, dataset: simgen.datasets.Dataset) -> None:
        self.dataset, self.root = dataset, dataset.root
        self._kept: dict[tuple[str, int], simgen.datasets.Frame] = {}

    def sequence(self, clip: str, index: int, length: int) -> list[simgen.datasets.Frame]:
        """`Dataset.sequence`: `length` consecutive frames of `clip` ending at `index`, oldest first."""
        if index - length + 1 < 0:
            return self.dataset.sequence(clip, index, length)  # its error
        keys = [(clip, i) for i in range(index - length + 1, index + 1)]
        self._kept = {key: self._kept[key] if key in self._kept else self.dataset.frame(*key) for key in keys}
        return list(self._kept.values())


class SampleSet(torch.utils.data.Dataset):
    """Encoded samples of a dataset split, in order; with `draws`, a seeded stream of augmented ones.

    Training draw k takes sample perm_e[k mod n] with e = k div n (a seeded permutation per epoch)
    and augments it with the generator seeded by (seed, k), so runs repeat whatever the workers.
    `assign` (the detector's target assigner) makes each sample's training targets.
    """

    def __init__(self, path: str, split: str | None, config: DetectorConfig, draws: int | None = None,
                 assign: Assign | None = None, first_draw: int = 0) -> None:
        self.path, self.config, self.draws, self.assign = path, config, draws, assign
        self.first_draw = first_draw  # a resumed fit's stream starts where the interrupted one stopped
        self.keys = sample_keys(simgen.datasets.open(path), split, config.data.split)
        self._dataset: RecentFrames | None = None  # opened again in each worker process

    def __len__(self) -> int:
        return self.draws - self.first_draw if self.draws is not None else len(self.keys)

    def key(self, item: int) -> tuple[str, int]:
        if self.draws is None:
            return self.keys[item]
        epoch, within = divmod(item, len(self.keys))
        return self.keys[np.random.default_rng([self.config.seed, epoch]).permutation(len(self.keys))[within]]

    def __getitem__(self, item: int) -> Encoded:
        item += self.first_draw
        if self._dataset is None:
            self._dataset = RecentFrames(simgen.datasets.open(self.path))
        sample = load_sample(self._dataset, *self.key(item), self.config)
        if self.draws is not None:
            sample = augment(sample, self.config.data.augment, np.random.default_rng([self.config.seed, 1, item]))
        return encode_sample(crop(sample, self.config.data.point_range_m), self.config, self.assign)


def _worker_start(parent: int, worker: int) -> None:
    """A loader worker's first step: die with `parent`, the process that iterates the loader."""
    die_with_parent(parent)


def loader(samples: SampleSet, batch_size: int, workers: int, collate_targets: Callable[[list], Any] | None = None,
           pin_memory: bool = False) -> Iterator[Batch]:
    """Batches in order, built by `workers` processes ahead of the model (0: in this process), which die
    with this one (train.parent_death).

    `pin_memory`: batches in page-locked memory, for `Batch.to(cuda, non_blocking=True)`.
    """
    rows, cols = samples.config.data.grid_size
    gather = functools.partial(
        collate, canvases=samples.config.model.fusion.canvases, grid_cells=rows * cols, collate_targets=collate_targets
    )
    return iter(
        torch.utils.data.DataLoader(
            samples,
            batch_size=batch_size,
            shuffle=False,
            num_workers=workers,
            collate_fn=gather,
            pin_memory=pin_memory,
            prefetch_factor=4 if workers else None,
            persistent_workers=False,
            worker_init_fn=functools.partial(_worker_start, os.getpid()),
        )
    )
