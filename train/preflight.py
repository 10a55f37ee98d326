"""What a detector run asks of the machine, checked from its config before anything is allocated.

Memory: an upper bound on the bytes that training (or inference) of a config needs, counted from
the config and its model built on the meta device (shapes without memory: `meta_detector`): the
parameters with their gradients and AdamW's two moments, the anchors, every feature map of a sample
that the forward pass keeps for the backward one (a conv's, its BatchNorm's and its ReLU's output, at
each layer, as a forward pass on the meta device makes them), the points' decorations and features, the
loss's per-anchor temporaries, the loader's prefetched batches, and the matrix of the NMS. It is
held to `MEMORY_SHARE` of the device's memory (the rest: Python, torch, the dataset reader, the
loader's processes); over it is one `UserError` line naming the field to change and its limit.
Points per frame come from the sensors (at most one point per shot): the dataset's manifest, or
the scenario a study will generate.

Loader processes are held to the CPU cores this process may use; a checkpoint to resume from must
be this config's; a list of seeds is bounded. All of it runs in a fraction of a second.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import torch

import simgen.datasets
from simgen.errors import UserError
from simgen.scenario import Scenario
from train.checkpoint import Checkpoint, load_checkpoint
from train.config import MAX_SEED, POINT_FEATURES, DetectorConfig, weight_fields
from train.detector.model import Detector

FLOAT = 4  # bytes of a float32; bfloat16 autocast halves the maps on CUDA, the estimate does not count on it
INDEX = 8  # bytes of an int64
GRADIENT_MAPS = 2  # the backward pass holds the gradients of a layer's output and of its input
TRAINING_COPIES = 4  # of each parameter: the weight, its gradient, AdamW's two moments
# Building the anchors (train.detector.anchors) holds float64 meshgrids and a float64 (N, 7) array before the
# float32 one; the model keeps one float32 copy as a buffer and the target assigner another.
ANCHOR_BYTES = 3 * 8 + 2 * 7 * 8 + 2 * 7 * FLOAT
LOSS_BYTES_PER_ANCHOR = 48  # the focal loss's ~10 float32 temporaries, the label, its masks
PREFETCH = 4  # batches each loader process builds ahead (train.data.loader)
# torch's kernels, autograd's and the optimizer's buffers on the first steps, whatever the model: a
# one-channel detector's first two training steps grow a process's anonymous memory by 79 MiB
# (tests/test_train_hostile.py measures it)
RUNTIME_BYTES = 256 << 20
# train.geometry.bev_iou of N boxes with each other: measured 3,890 bytes a pair at its peak when every
# pair overlaps (41 when none does); NMS runs it on up to `infer.pre_nms` boxes.
NMS_BYTES_PER_PAIR = 4096
MEMORY_SHARE = 0.8  # of the device's memory a run may plan to use
PARTS = ("pillar_encoder", "backbone_2d", "fusion", "head")  # train.detector.model.Detector's
# The field whose channels make each part's weights
WIDTHS = {"pillar_encoder": "model.pillar_encoder.channels", "backbone_2d": "model.backbone_2d.channels",
          "fusion": "model.backbone_2d.upsample_channels", "head": "model.backbone_2d.upsample_channels"}
MAX_SEEDS = 100  # `study --seeds`: each seed trains every model again
GIB = 1 << 30


@dataclass(frozen=True)
class MemoryEstimate:
    """Upper bounds in bytes; a run needs `fixed + batch * per_sample + nms`."""

    parameters: int  # count, all parts
    fixed: int  # parameters (and, training, their gradients and AdamW's moments), the anchors, torch's own
    per_sample: int  # feature maps, points, anchor targets and loss of one sample
    points: int  # of per_sample: the points' features and decorations
    nms: int  # the NMS matrix of `infer.pre_nms` boxes (inference, and training's learning curve)

    def total(self, batch: int) -> int:
        return self.fixed + batch * self.per_sample + self.nms


def meta_detector(config: DetectorConfig) -> Detector:
    """The config's detector on the meta device (shapes, no memory). Its anchors lie on a stand-in grid of one
    output cell: the weights do not depend on the grid, and no config's anchors are made before they are weighed."""
    cell_m = config.data.pillar_size_m * config.model.backbone_2d.output_stride
    x0, y0, z0, _, _, z1 = config.data.point_range_m
    one_cell = config.data.model_copy(update={"point_range_m": (x0, y0, z0, x0 + cell_m, y0 + cell_m, z1)})
    with torch.device("meta"):
        return Detector(config.model_copy(update={"data": one_cell}))


def parameter_counts(config: DetectorConfig) -> dict[str, int]:
    """Weights of each part of train.detector.model.Detector (BatchNorm's running statistics included): the
    floating-point tensors of each part's state dict, counted on its meta-device build."""
    model = meta_detector(config)
    return {part: sum(t.numel() for t in getattr(model, part).state_dict().values() if t.is_floating_point())
            for part in PARTS}


def _sample_maps(config: DetectorConfig) -> list[int]:
    """Elements of each float32 feature map one sample's forward pass makes, found by running it on the meta
    device from the pseudo-images: every tensor a module of the backbone, the fusion or the head reads or
    makes (each conv's, BatchNorm's and ReLU's output, the levels concatenated), the head's outputs per anchor,
    and the pseudo-images twice more (train.detector.sparse_canvas: the zeros and the pillars scattered)."""
    model, (rows, cols) = meta_detector(config), config.data.grid_size
    canvases = config.model.fusion.canvases
    seen: dict[int, torch.Tensor] = {}  # by id, each held so that no id is reused

    def record(module: torch.nn.Module, inputs: tuple, output: object) -> None:
        for tensor in (*inputs, output):
            if isinstance(tensor, torch.Tensor):
                seen[id(tensor)] = tensor

    for part in ("backbone_2d", "fusion", "head"):
        for module in getattr(model, part).modules():
            if not list(module.children()):
                module.register_forward_hook(record)
    image = torch.empty(canvases, config.model.pillar_encoder.channels, rows, cols, device="meta")
    out = model.head(model.fusion(model.backbone_2d(image), 1))
    maps = [tensor.numel() for tensor in seen.values()]
    return maps + [image.numel()] * 2 + [out.scores.numel(), out.deltas.numel(), out.direction.numel()]


def estimate_memory(config: DetectorConfig, points_per_frame: int, training: bool, host: bool) -> MemoryEstimate:
    """Bytes to train (or run) `config` on frames of at most `points_per_frame` points. `host`: the
    device is this machine's memory, which also holds the loader's prefetched batches."""
    parameters = sum(parameter_counts(config).values())
    anchors = config.anchors
    fixed = parameters * FLOAT * (TRAINING_COPIES if training else 1) + anchors * ANCHOR_BYTES + RUNTIME_BYTES
    maps = _sample_maps(config)
    per_sample = FLOAT * (sum(maps) + (GRADIENT_MAPS * max(maps) if training else 0))
    points = config.model.fusion.input_frames * points_per_frame
    features = POINT_FEATURES + int(config.model.fusion.time_channel)
    channels = config.model.pillar_encoder.channels
    # each point: its features, decorated twice, its offsets, the Linear, BatchNorm and ReLU and their gradients;
    # its pillar index, the unique sort's and the inverse's indices
    point_bytes = points * (FLOAT * (3 * features + 24 + 6 * channels) + 6 * INDEX)
    per_sample += point_bytes
    per_sample += (anchors * LOSS_BYTES_PER_ANCHOR) if training else anchors * 2 * FLOAT  # loss, or sigmoid and sort
    if host:
        in_flight = PREFETCH * max(config.train.workers, 1)
        per_sample += in_flight * (points * (features * FLOAT + INDEX) + anchors)
    nms = config.infer.pre_nms**2 * NMS_BYTES_PER_PAIR if (not training or config.train.eval_every) else 0
    return MemoryEstimate(parameters, fixed, per_sample, point_bytes, nms)


def device_memory(device: torch.device) -> int:
    """Bytes of the device: a CUDA device's memory, or this machine's (within its cgroup's limit)."""
    if device.type == "cuda":
        return torch.cuda.get_device_properties(device).total_memory
    memory = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    for limit in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(limit).read_text().strip()
        except OSError:
            continue
        if text.isdigit():
            memory = min(memory, int(text))
    return memory


def _gib(size: float) -> str:
    return f"{size / GIB:,.1f} GiB"


def check_memory(config: DetectorConfig, points_per_frame: int, device: torch.device, training: bool,
                 batch: int | None = None, memory: int | None = None) -> MemoryEstimate:
    """`UserError` naming the field to change when training (or inference on batches of `batch`) would not
    fit in `MEMORY_SHARE` of the device's memory (`memory` bytes; default: the device's)."""
    memory = device_memory(device) if memory is None else memory
    budget = int(MEMORY_SHARE * memory)
    batch = config.train.batch_size if batch is None else batch
    estimate = estimate_memory(config, points_per_frame, training, host=device.type == "cpu")
    if estimate.total(batch) <= budget:
        return estimate
    what = "training" if training else "inference"
    room = f"over the {_gib(budget)} a run may use of this {device.type}'s {_gib(memory)}"
    if estimate.fixed > budget:
        part = max(parameter_counts(config).items(), key=lambda item: item[1])[0]
        field = "model.head.anchor.yaws_rad" if config.anchors * ANCHOR_BYTES > estimate.fixed // 2 else WIDTHS[part]
        raise UserError(f"'{field}': {estimate.parameters:,} parameters and {config.anchors:,} anchors need "
                        f"{_gib(estimate.fixed)} for {what} before any sample, {room}")
    least = 1 if training else batch  # samples a run cannot do with fewer
    samples = estimate.fixed + least * estimate.per_sample
    if samples > budget:
        some = f"{least} sample{'s' * (least > 1)}"
        needs = f"need{'s' * (least == 1)} {_gib(samples)} for {what}, {room}"
        if 2 * estimate.points > estimate.per_sample:
            raise UserError(
                f"'model.pillar_encoder.channels': {some} of up to {points_per_frame:,} points a frame (the sensors' "
                f"shots) with {config.model.pillar_encoder.channels:,} channels a point {needs}"
            )
        rows, cols = config.data.grid_size
        widest = max(config.model.pillar_encoder.channels, *config.model.backbone_2d.channels)
        raise UserError(
            f"'data.pillar_size_m': {some} of the {rows:,} x {cols:,} pillar grid with maps of up to {widest:,} "
            f"channels ('model.*.channels') {needs}"
        )
    if samples + estimate.nms > budget:
        fits = math.isqrt((budget - samples) // NMS_BYTES_PER_PAIR)
        raise UserError(
            f"'infer.pre_nms': NMS of {config.infer.pre_nms:,} boxes may need {_gib(estimate.nms)} more, {room}; "
            f"at most {fits:,} boxes here"
        )
    fits = (budget - estimate.fixed - estimate.nms) // estimate.per_sample
    raise UserError(f"'train.batch_size': {batch:,} samples need {_gib(estimate.total(batch))} for {what}, {room}; "
                    f"at most {fits:,} a batch here")


def dataset_points_per_frame(dataset: simgen.datasets.Dataset) -> int:
    """Most points a frame of the dataset can hold: the shots its sensors fire in a frame (manifest)."""
    return math.ceil(sum(s.shots_per_s / s.frame_rate_hz for s in dataset.manifest.sensors))


def scenario_points_per_frame(scenario: Scenario) -> int:
    """Most points a frame of the scenario's dataset can hold, before it is generated."""
    return math.ceil(scenario.shots_per_frame())


def cpu_cores() -> int:
    """CPU cores this process may run on (its affinity, which containers and taskset narrow)."""
    return len(os.sched_getaffinity(0))


def check_workers(config: DetectorConfig, option: str = "--workers") -> None:
    """`UserError` when the config asks for more loader processes than this machine has cores."""
    cores = cpu_cores()
    if config.train.workers > cores:
        raise UserError(f"'train.workers': {config.train.workers} loader processes, this machine has {cores} CPU cores "
                        f"(at most {cores}; {option} overrides it)")


def check_resume(path: str | Path, config: DetectorConfig) -> Checkpoint:
    """The checkpoint at `path` if training `config` can go on from it; else one `UserError` line: not a
    checkpoint of simgen-train, another model or training (a field other than `infer` and
    NOT_WEIGHTS_TRAIN differs), no optimizer state, or nothing left to train. Whether its weights fit
    the model is found when they are loaded into it (`load_state_dict`)."""
    checkpoint = load_checkpoint(path)
    differs = _first_difference(weight_fields(checkpoint.config), weight_fields(config))
    if differs is not None:
        field, was, now = differs
        raise UserError(f"{path}: trained with '{field}' {_short(was)}, this config has {_short(now)}: "
                        f"a run resumes only the same training")
    if not checkpoint.optimizer:
        raise UserError(f"{path}: holds no optimizer state to resume from")
    if not 0 < checkpoint.iteration < config.train.iterations:
        raise UserError(f"{path}: at iteration {checkpoint.iteration} of 'train.iterations' {config.train.iterations}: "
                        f"nothing to resume")
    return checkpoint


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _first_difference(a: object, b: object, at: str = "") -> tuple[str, object, object] | None:
    """(dotted field, a's value, b's value) of the first field where two JSON trees differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            found = _first_difference(a.get(key), b.get(key), f"{at}.{key}" if at else key)
            if found is not None:
                return found
        return None
    return None if a == b else (at, a, b)


def parse_seeds(text: str, option: str = "--seeds") -> tuple[int, ...]:
    """`0,1,2` -> (0, 1, 2): distinct seeds in [0, MAX_SEED], at most MAX_SEEDS; else one `UserError` line."""
    parts = text.split(",")
    if len(parts) > MAX_SEEDS:
        raise UserError(f"{option}: {len(parts)} seeds, at most {MAX_SEEDS} (each trains every model again)")
    seeds = []
    for part in parts:
        word = part.strip()
        if not (word.isascii() and word.isdigit()) or len(word) > len(str(MAX_SEED)) or int(word) > MAX_SEED:
            raise UserError(f"{option}: {word[:20]!r} is not a seed (a whole number from 0 to {MAX_SEED:,})")
        seeds.append(int(word))
    if len(set(seeds)) < len(seeds):
        raise UserError(f"{option}: seed {next(s for s in seeds if seeds.count(s) > 1)} is given twice")
    return tuple(seeds)
