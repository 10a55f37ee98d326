"""The detector's config file (one per model, as OpenPCDet's): data, model, loss, training, inference.

Validated by pydantic: an unknown key, a wrong type or range is one `UserError` line naming the
field. Lengths in metres, angles in radians.

Every number is bounded, so that no config can ask for more than a machine can hold before the
memory check (train.preflight) weighs the whole model against the device. Each bound's derivation
is beside it; docs/reliability.md lists them.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from simgen.errors import UserError
from simgen.validation import Strict, read_yaml, validate

TRACKLET_FRAMES = 3  # t-2, t-1, t
POINT_FEATURES = 4  # x, y, z metres, intensity 0-1 per point (early fusion adds the frame offset)

# Where points can be: simgen.scenario puts sensors within 200 m of the centre spot (100 m up) and
# no Livox return comes from beyond 1,000 m, so no point of a simgen dataset lies beyond 1,200 m.
MAX_RANGE_M = 1200.0
MIN_PILLAR_M = 0.01  # 1 cm: half a Livox Mid's 2 cm range precision, so a finer pillar holds nothing more
# The pillar grid (range / pillar size): 4,096 x 4,096 pillars, 164 x the paper's 320 x 320. One
# float32 feature map of it is 64 MiB a channel, so even the smallest detector (one channel, one
# layer a block) needs 2 GiB a sample to train (train.preflight's estimate, which weighs the rest).
MAX_GRID_CELLS = 1 << 24
MAX_CHANNELS = 1024  # per layer: 4 x the paper's widest (256); a 3x3 conv of 1,024 -> 1,024 is 9.4 M weights
MAX_LAYERS = 32  # per backbone block (the paper: 4, 6, 6)
MAX_STRIDE = 8  # per block and per upsampling (the paper: 1 or 2, and 1, 2, 4)
MAX_ANCHORS_PER_CELL = 16  # anchor yaws (the paper: 2)
# Anchors on the output grid: each costs 28 bytes in the model, 28 in the target assigner, 1 a
# sample for its label and 48 a sample in the loss; 2^25 is the finest grid's two anchors a cell.
MAX_ANCHORS = 1 << 25
MAX_BATCH = 1024  # samples: more than a paper dataset's whole train split (609); the memory check decides below it
MAX_ITERATIONS = 10_000_000  # 115 days at 1 batch/s; iterations x batch stays far below the loader's 2^63 draws
MAX_WORKERS = 512  # loader processes; train.preflight also holds them to the machine's CPU cores
MAX_LR = 1.0  # AdamW moves a weight by about lr a step: beyond 1, one step outweighs the weights' scale
MAX_PRE_NMS = 4096  # OpenPCDet's NMS_PRE_MAXSIZE; the NMS matrix is then 16.8 M pairs (train.preflight counts it)
MAX_DETECTIONS = 500  # OpenPCDet's NMS_POST_MAXSIZE, 20 x the 25 humanoids a pitch holds
MAX_SEED = 2**31 - 1  # as simgen.scenario


Name = Annotated[str, Field(pattern=r"^[^\x00-\x1f\x7f]+$", min_length=1, max_length=64)]  # one printable line
Coordinate = Annotated[float, Field(ge=-MAX_RANGE_M, le=MAX_RANGE_M)]
Channels = Annotated[int, Field(ge=1, le=MAX_CHANNELS)]
Stride = Annotated[int, Field(ge=1, le=MAX_STRIDE)]
Layers = Annotated[int, Field(ge=1, le=MAX_LAYERS)]
Angle = Annotated[float, Field(ge=-6.2832, le=6.2832)]
Weight = Annotated[float, Field(ge=0.0, le=1000.0)]


class AugmentConfig(Strict):
    """Global augmentation, the same for the three frames of a sample (training only)."""

    rotation_rad: float = Field(0.785, ge=0.0, le=3.1416)  # uniform in [-r, r] about z through the origin
    flip_x: bool = True  # mirror x -> -x with probability 1/2 (keeps a touchline sensor's view)
    scale: tuple[float, float] = (0.95, 1.05)  # uniform factor range, each in (0, 10]

    @model_validator(mode="after")
    def _ordered(self) -> AugmentConfig:
        if not 0.0 < self.scale[0] <= self.scale[1] <= 10.0:
            raise ValueError("'data.augment.scale': needs 0 < low <= high <= 10")
        return self


class DataConfig(Strict):
    # x0, y0, z0, x1, y1, z1, each within MAX_RANGE_M of the centre spot
    point_range_m: tuple[Coordinate, Coordinate, Coordinate, Coordinate, Coordinate, Coordinate] = (
        -40.0, -40.0, -0.1, 40.0, 40.0, 2.5)
    pillar_size_m: float = Field(0.25, ge=MIN_PILLAR_M, le=2 * MAX_RANGE_M)
    classes: tuple[Name, ...] = Field(("Pedestrian", "Official"), min_length=1, max_length=16)  # detected as one class
    augment: AugmentConfig = AugmentConfig()
    # Which samples are train and val (train.data.sample_keys): `clip`, the dataset's own split (whole clips
    # held out); `frame`, every k-th t-2..t window of all clips held out (the paper does not say which it used).
    split: Literal["clip", "frame"] = "clip"

    @model_validator(mode="after")
    def _grid(self) -> DataConfig:
        x0, y0, z0, x1, y1, z1 = self.point_range_m
        if not (x0 < x1 and y0 < y1 and z0 < z1):
            raise ValueError("'data.point_range_m': needs x0 < x1, y0 < y1, z0 < z1")
        for span in (x1 - x0, y1 - y0):
            cells = span / self.pillar_size_m
            if abs(cells - round(cells)) > 1e-6:
                raise ValueError("'data.point_range_m': x and y spans must be whole multiples of pillar_size_m")
        return self

    @property
    def grid_size(self) -> tuple[int, int]:
        """(rows along y, columns along x) of the pillar grid."""
        x0, y0, _, x1, y1, _ = self.point_range_m
        return round((y1 - y0) / self.pillar_size_m), round((x1 - x0) / self.pillar_size_m)


class PillarEncoderConfig(Strict):
    """PointPillars' pillar feature net: one Linear + BatchNorm + ReLU per point, max over the pillar."""

    name: Literal["pillar_vfe"] = "pillar_vfe"
    channels: Channels = 16  # features per pillar (the pseudo-image's channels)
    # Point decorations divided by their span (x, y by the range's half-width, z by its half-height,
    # offsets by the pillar size, the frame offset by 2) so that none dwarfs another before the Linear.
    scale_inputs: bool = False


class Backbone2dConfig(Strict):
    """PointPillars' top-down blocks (pedestrian: 4, 6, 6 layers) and their upsampling to one size."""

    name: Literal["pointpillars"] = "pointpillars"
    layers: tuple[Layers, Layers, Layers] = (4, 6, 6)
    strides: tuple[Stride, Stride, Stride] = (2, 2, 2)
    channels: tuple[Channels, Channels, Channels] = (8, 16, 32)
    upsample_strides: tuple[Stride, Stride, Stride] = (1, 2, 4)
    upsample_channels: tuple[Channels, Channels, Channels] = (16, 16, 16)

    @property
    def output_stride(self) -> int:
        """Pillars per output cell along each axis."""
        return self.strides[0] // self.upsample_strides[0]

    @model_validator(mode="after")
    def _common_size(self) -> Backbone2dConfig:
        total, sizes = 1, []
        for stride, up in zip(self.strides, self.upsample_strides):
            total *= stride
            sizes.append(total / up)
        if len(set(sizes)) != 1 or sizes[0] != int(sizes[0]):
            raise ValueError(
                "'model.backbone_2d': every block must upsample to the same size (strides / upsample_strides)"
            )
        return self


class SingleFrameConfig(Strict):
    """Frame t alone (the paper's single-frame baseline)."""

    name: Literal["single"]
    input_frames: ClassVar[int] = 1  # point clouds read per sample
    canvases: ClassVar[int] = 1  # pseudo-images per sample
    time_channel: ClassVar[bool] = False  # points carry their frame offset (-2, -1, 0)


class EarlyFusionConfig(Strict):
    """The three sweeps merged into one cloud with a time channel, one backbone pass."""

    name: Literal["early"]
    input_frames: ClassVar[int] = TRACKLET_FRAMES
    canvases: ClassVar[int] = 1
    time_channel: ClassVar[bool] = True


class LateFusionConfig(Strict):
    """The paper's module: one backbone pass per frame, a 3x3x3 Conv3d per level over the frames."""

    name: Literal["late"]
    input_frames: ClassVar[int] = TRACKLET_FRAMES
    canvases: ClassVar[int] = TRACKLET_FRAMES
    time_channel: ClassVar[bool] = False


FusionConfig = Annotated[SingleFrameConfig | EarlyFusionConfig | LateFusionConfig, Field(discriminator="name")]
OLD_FUSION_NAMES = {"none": "single"}  # read with a FutureWarning: configs and checkpoints written before the rename


Size = Annotated[float, Field(gt=0.0, le=20.0)]  # no object on a pitch is 20 m across (a goal: 7.3 m)


class AnchorConfig(Strict):
    size_m: tuple[Size, Size, Size] = (0.8, 0.8, 1.7)  # length, width, height
    z_m: Coordinate = 0.85  # centre height
    # anchors per cell
    yaws_rad: tuple[Angle, ...] = Field((0.0, 1.5708), min_length=1, max_length=MAX_ANCHORS_PER_CELL)
    match_iou: float = Field(0.5, gt=0.0, le=1.0)  # BEV IoU with the box at t: positive at or above
    unmatch_iou: float = Field(0.35, ge=0.0, le=1.0)  # negative below; ignored between


class BoxCoderConfig(Strict):
    name: Literal["residual"] = "residual"  # SECOND's residual coding (train.detector.box_coder)


class DenseHeadConfig(Strict):
    """SSD-style dense head: per anchor a score, K boxes (t-2, t-1, t or t only) and a direction bin."""

    name: Literal["anchor_head"] = "anchor_head"
    tracklet_boxes: Literal[1, 3] = 1  # boxes regressed per anchor: t only, or t-2, t-1, t
    anchor: AnchorConfig = AnchorConfig()
    box_coder: BoxCoderConfig = BoxCoderConfig()
    dir_offset_rad: Angle = 0.78539


class ModelConfig(Strict):
    """The detector's named parts, each built by its registry (train.detector.registry)."""

    pillar_encoder: PillarEncoderConfig = PillarEncoderConfig()
    backbone_2d: Backbone2dConfig = Backbone2dConfig()
    fusion: FusionConfig
    head: DenseHeadConfig = DenseHeadConfig()

    @property
    def method(self) -> str:
        """The paper's name of this model (its fusion's): single, early or late."""
        return self.fusion.name

    @model_validator(mode="after")
    def _boxes(self) -> ModelConfig:
        if self.fusion.input_frames == 1 and self.head.tracklet_boxes != 1:
            raise ValueError("'model.head.tracklet_boxes': a single-frame model regresses 1 box")
        return self


class LossConfig(Strict):
    """Paper eq. 2: alpha L_cls + sum_i lambda_i L_loc^i + beta L_dir."""

    cls_weight: Weight = 1.0  # alpha
    # lambda for t-2, t-1, t (the last ones used)
    loc_weights: tuple[Weight, ...] = Field((2.0, 2.0, 2.0), min_length=1, max_length=TRACKLET_FRAMES)
    dir_weight: Weight = 0.2  # beta
    focal_alpha: float = Field(0.25, ge=0.0, le=1.0)
    focal_gamma: float = Field(2.0, ge=0.0, le=10.0)
    smooth_l1_beta: float = Field(1.0 / 9.0, gt=0.0, le=10.0)


class TrainConfig(Strict):
    iterations: int = Field(2000, ge=1, le=MAX_ITERATIONS)
    batch_size: int = Field(2, ge=1, le=MAX_BATCH)
    lr: float = Field(0.003, gt=0.0, le=MAX_LR)  # peak of the one-cycle schedule
    weight_decay: float = Field(0.01, ge=0.0, le=1.0)  # AdamW shrinks weights by lr x weight_decay a step: at most all
    grad_clip: float = Field(10.0, gt=0.0, le=1e6)
    workers: int = Field(2, ge=0, le=MAX_WORKERS)
    checkpoint_every: int = Field(500, ge=1, le=MAX_ITERATIONS)
    log_every: int = Field(10, ge=1, le=MAX_ITERATIONS)
    # learning curve: AP on the val clips every this many iterations (0: none)
    eval_every: int = Field(0, ge=0, le=MAX_ITERATIONS)
    bf16: Literal["auto", "on", "off"] = "auto"  # bfloat16 autocast; auto: on CUDA only
    # a step's speed on a GPU (train.accelerate); auto: on CUDA only
    cudnn_benchmark: Literal["auto", "on", "off"] = "auto"
    channels_last: Literal["auto", "on", "off"] = "auto"
    compile: Literal["auto", "on", "off"] = "off"


class InferConfig(Strict):
    score_threshold: float = Field(0.1, ge=0.0, le=1.0)
    pre_nms: int = Field(500, ge=1, le=MAX_PRE_NMS)
    nms_iou: float = Field(0.2, gt=0.0, le=1.0)  # BEV IoU of the boxes at t
    max_detections: int = Field(100, ge=1, le=MAX_DETECTIONS)


class DetectorConfig(Strict):
    name: Name
    seed: int = Field(0, ge=0, le=MAX_SEED)
    data: DataConfig = DataConfig()
    model: ModelConfig
    loss: LossConfig = LossConfig()
    train: TrainConfig = TrainConfig()
    infer: InferConfig = InferConfig()

    @model_validator(mode="after")
    def _bounds(self) -> DetectorConfig:
        """Checks across fields, here so that the line names the field by its whole path."""
        x0, y0, _, x1, y1, _ = self.data.point_range_m
        size = self.data.pillar_size_m
        rows, cols = (y1 - y0) / size, (x1 - x0) / size
        if rows * cols > MAX_GRID_CELLS:
            finest = ((x1 - x0) * (y1 - y0) / MAX_GRID_CELLS) ** 0.5
            raise ValueError(
                f"'data.pillar_size_m': {size:g} m makes a {rows:,.0f} x {cols:,.0f} pillar grid (range / pillar "
                f"size); at most {MAX_GRID_CELLS:,} pillars, so at least {finest:.6g} m for this point_range_m"
            )
        anchor, infer = self.model.head.anchor, self.infer
        if self.anchors > MAX_ANCHORS:
            raise ValueError(
                f"'model.head.anchor.yaws_rad': {self.anchors:,} anchors ({len(anchor.yaws_rad)} per output cell); "
                f"at most {MAX_ANCHORS:,}"
            )
        if anchor.unmatch_iou > anchor.match_iou:
            raise ValueError(
                f"'model.head.anchor.unmatch_iou': {anchor.unmatch_iou:g} is above match_iou {anchor.match_iou:g}"
            )
        if infer.max_detections > infer.pre_nms:
            raise ValueError(
                f"'infer.max_detections': {infer.max_detections} is more than the {infer.pre_nms} boxes NMS sees "
                f"(infer.pre_nms)"
            )
        return self

    @model_validator(mode="after")
    def _weights(self) -> DetectorConfig:
        boxes = self.model.head.tracklet_boxes
        if len(self.loss.loc_weights) < boxes:
            raise ValueError(f"'loss.loc_weights': needs {boxes} weights")
        cells, strides = self.data.grid_size, self.model.backbone_2d.strides
        stride = strides[0] * strides[1] * strides[2]
        if any(c % stride for c in cells):
            raise ValueError(
                f"'model.backbone_2d.strides': the {cells[0]}x{cells[1]} pillar grid must divide by {stride}"
            )
        return self

    @property
    def output_grid(self) -> tuple[int, int]:
        """(rows, columns) of the head's output grid: the pillar grid coarsened by the backbone's output stride."""
        stride = self.model.backbone_2d.output_stride
        return self.data.grid_size[0] // stride, self.data.grid_size[1] // stride

    @property
    def anchors(self) -> int:
        """Anchors per sample: output cells x yaws."""
        rows, cols = self.output_grid
        return rows * cols * len(self.model.head.anchor.yaws_rad)


# Training settings that do not change the weights (the loader's draws are seeded per sample, not per process).
NOT_WEIGHTS_TRAIN = ("workers", "log_every", "checkpoint_every", "eval_every")


def weight_fields(config: DetectorConfig) -> dict:
    """The config as JSON without what does not change the weights (`infer` and NOT_WEIGHTS_TRAIN)."""
    data = config.model_dump(mode="json")
    del data["infer"]
    data["train"] = {k: v for k, v in data["train"].items() if k not in NOT_WEIGHTS_TRAIN}
    return data


def same_weights(a: DetectorConfig, b: DetectorConfig) -> bool:
    """Whether training with `a` and with `b` gives the same weights (they differ at most in `infer` and
    NOT_WEIGHTS_TRAIN)."""
    return weight_fields(a) == weight_fields(b)


def _renamed(data: object, source: str) -> object:
    """`data` with an old `model.fusion.name` (OLD_FUSION_NAMES) replaced by its name now, with a one-line
    FutureWarning naming `source`; anything else as given."""
    fusion = data.get("model") if isinstance(data, dict) else None
    fusion = fusion.get("fusion") if isinstance(fusion, dict) else None
    old = fusion.get("name") if isinstance(fusion, dict) else None
    if not isinstance(old, str) or old not in OLD_FUSION_NAMES:
        return data
    new = OLD_FUSION_NAMES[old]
    warnings.warn(f"{source}: 'model.fusion.name: {old}' is deprecated, read as {new} (write {new})",
                  FutureWarning, stacklevel=3)
    return {**data, "model": {**data["model"], "fusion": {**fusion, "name": new}}}


def parse_config(data: object, source: str = "config") -> DetectorConfig:
    """Validate a parsed config; raise `UserError` naming the first bad field."""
    return validate(DetectorConfig, _renamed(data, source), source)


MAX_BASES = 4  # configs chained by `base` (a cycle ends here)


def _overlaid(base: object, over: object) -> object:
    """`over` on top of `base`: mappings merged key by key, anything else replaced."""
    if not isinstance(base, dict) or not isinstance(over, dict):
        return over
    return {**base, **{key: _overlaid(base.get(key), value) for key, value in over.items()}}


def _read_with_base(path: Path, chained: int = 0) -> object:
    """A config file's document; with `base: FILE.yaml` (a path from its folder), that config's document with this
    one's keys laid over it (a whole-pitch config is the compact one with another `data.point_range_m`)."""
    data = read_yaml(path, "config")
    if not isinstance(data, dict) or "base" not in data:
        return data
    base = data["base"]
    if not isinstance(base, str) or not base.endswith(".yaml"):
        raise UserError(f"{path}: 'base' must name a config .yaml file, relative to this one's folder")
    if chained >= MAX_BASES:
        raise UserError(f"{path}: more than {MAX_BASES} configs chained by 'base' (a cycle?)")
    return _overlaid(_read_with_base(path.parent / base, chained + 1), {k: v for k, v in data.items() if k != "base"})


def load_config(path: str | Path) -> DetectorConfig:
    """Read and validate a detector config YAML file (with its `base` config, if it names one)."""
    return parse_config(_read_with_base(Path(path)), str(path))
