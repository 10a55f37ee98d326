"""The detector's config file (one per model, as OpenPCDet's): data, model, loss, training, inference.

Validated by pydantic: an unknown key, a wrong type or range is one `UserError` line naming the
field. Lengths in metres, angles in radians.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgen.validation import read_yaml, validate

TRACKLET_FRAMES = 3  # t-2, t-1, t
POINT_FEATURES = 4  # x, y, z metres, intensity 0-1 per point (early fusion adds the frame offset)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class AugmentConfig(_Strict):
    """Global augmentation, the same for the three frames of a sample (training only)."""

    rotation_rad: float = Field(0.785, ge=0.0, le=3.1416)  # uniform in [-r, r] about z through the origin
    flip_x: bool = True  # mirror x -> -x with probability 1/2 (keeps a touchline sensor's view)
    scale: tuple[float, float] = (0.95, 1.05)  # uniform factor range

    @model_validator(mode="after")
    def _ordered(self) -> "AugmentConfig":
        if not 0.0 < self.scale[0] <= self.scale[1]:
            raise ValueError("'data.augment.scale': needs 0 < low <= high")
        return self


class DataConfig(_Strict):
    point_range_m: tuple[float, float, float, float, float, float] = (-40.0, -40.0, -0.1, 40.0, 40.0, 2.5)
    pillar_size_m: float = Field(0.25, gt=0.0)
    classes: tuple[str, ...] = ("Pedestrian", "Official")  # label classes detected, as one class
    augment: AugmentConfig = AugmentConfig()
    # Which samples are train and val (train.data.sample_keys): `clip`, the dataset's own split (whole clips
    # held out); `frame`, every k-th t-2..t window of all clips held out (the paper does not say which it used).
    split: Literal["clip", "frame"] = "clip"

    @model_validator(mode="after")
    def _grid(self) -> "DataConfig":
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


class PillarEncoderConfig(_Strict):
    """PointPillars' pillar feature net: one Linear + BatchNorm + ReLU per point, max over the pillar."""

    name: Literal["pillar_vfe"] = "pillar_vfe"
    channels: int = Field(16, ge=1)  # features per pillar (the pseudo-image's channels)
    # Point decorations divided by their span (x, y by the range's half-width, z by its half-height,
    # offsets by the pillar size, the frame offset by 2) so that none dwarfs another before the Linear.
    scale_inputs: bool = False


class Backbone2dConfig(_Strict):
    """PointPillars' top-down blocks (pedestrian: 4, 6, 6 layers) and their upsampling to one size."""

    name: Literal["pointpillars"] = "pointpillars"
    layers: tuple[int, int, int] = (4, 6, 6)
    strides: tuple[int, int, int] = (2, 2, 2)
    channels: tuple[int, int, int] = (8, 16, 32)
    upsample_strides: tuple[int, int, int] = (1, 2, 4)
    upsample_channels: tuple[int, int, int] = (16, 16, 16)

    @property
    def output_stride(self) -> int:
        """Pillars per output cell along each axis."""
        return self.strides[0] // self.upsample_strides[0]

    @model_validator(mode="after")
    def _common_size(self) -> "Backbone2dConfig":
        total, sizes = 1, []
        for stride, up in zip(self.strides, self.upsample_strides):
            total *= stride
            sizes.append(total / up)
        if len(set(sizes)) != 1 or sizes[0] != int(sizes[0]):
            raise ValueError("'model.backbone_2d': every block must upsample to the same size (strides / upsample_strides)")
        return self


class NoFusionConfig(_Strict):
    """Frame t alone (the paper's single-frame baseline)."""

    name: Literal["none"]
    input_frames: ClassVar[int] = 1  # point clouds read per sample
    canvases: ClassVar[int] = 1  # pseudo-images per sample
    time_channel: ClassVar[bool] = False  # points carry their frame offset (-2, -1, 0)


class EarlyFusionConfig(_Strict):
    """The three sweeps merged into one cloud with a time channel, one backbone pass."""

    name: Literal["early"]
    input_frames: ClassVar[int] = TRACKLET_FRAMES
    canvases: ClassVar[int] = 1
    time_channel: ClassVar[bool] = True


class LateFusionConfig(_Strict):
    """The paper's module: one backbone pass per frame, a 3x3x3 Conv3d per level over the frames."""

    name: Literal["late"]
    input_frames: ClassVar[int] = TRACKLET_FRAMES
    canvases: ClassVar[int] = TRACKLET_FRAMES
    time_channel: ClassVar[bool] = False


FusionConfig = Annotated[NoFusionConfig | EarlyFusionConfig | LateFusionConfig, Field(discriminator="name")]
METHODS = {"none": "single", "early": "early", "late": "late"}  # fusion name -> the paper's Table 1 method


class AnchorConfig(_Strict):
    size_m: tuple[float, float, float] = (0.8, 0.8, 1.7)  # length, width, height
    z_m: float = 0.85  # centre height
    yaws_rad: tuple[float, ...] = (0.0, 1.5708)  # two anchors per cell, 0 and 90 degrees
    match_iou: float = Field(0.5, gt=0.0, le=1.0)  # BEV IoU with the box at t: positive at or above
    unmatch_iou: float = Field(0.35, ge=0.0, le=1.0)  # negative below; ignored between


class BoxCoderConfig(_Strict):
    name: Literal["residual"] = "residual"  # SECOND's residual coding (train.models.box_coder)


class HeadConfig(_Strict):
    """SSD-style dense head: per anchor a score, K boxes (t-2, t-1, t or t only) and a direction bin."""

    name: Literal["anchor_head"] = "anchor_head"
    tracklet_boxes: Literal[1, 3] = 1  # boxes regressed per anchor: t only, or t-2, t-1, t
    anchor: AnchorConfig = AnchorConfig()
    box_coder: BoxCoderConfig = BoxCoderConfig()
    dir_offset_rad: float = 0.78539


class ModelConfig(_Strict):
    """The detector's named parts, each built by its registry (train.models.registry)."""

    pillar_encoder: PillarEncoderConfig = PillarEncoderConfig()
    backbone_2d: Backbone2dConfig = Backbone2dConfig()
    fusion: FusionConfig
    head: HeadConfig = HeadConfig()

    @property
    def method(self) -> str:
        """The paper's name of this model: single, early or late."""
        return METHODS[self.fusion.name]

    @model_validator(mode="after")
    def _boxes(self) -> "ModelConfig":
        if self.fusion.input_frames == 1 and self.head.tracklet_boxes != 1:
            raise ValueError("'model.head.tracklet_boxes': a single-frame model regresses 1 box")
        return self


class LossConfig(_Strict):
    """Paper eq. 2: alpha L_cls + sum_i lambda_i L_loc^i + beta L_dir."""

    cls_weight: float = 1.0  # alpha
    loc_weights: tuple[float, ...] = (2.0, 2.0, 2.0)  # lambda for t-2, t-1, t (the last ones used)
    dir_weight: float = 0.2  # beta
    focal_alpha: float = 0.25
    focal_gamma: float = 2.0
    smooth_l1_beta: float = 1.0 / 9.0


class TrainConfig(_Strict):
    iterations: int = Field(2000, ge=1)
    batch_size: int = Field(2, ge=1)
    lr: float = Field(0.003, gt=0.0)  # peak of the one-cycle schedule
    weight_decay: float = Field(0.01, ge=0.0)
    grad_clip: float = Field(10.0, gt=0.0)
    workers: int = Field(2, ge=0)
    checkpoint_every: int = Field(500, ge=1)
    log_every: int = Field(10, ge=1)
    eval_every: int = Field(0, ge=0)  # learning curve: AP on the val clips every this many iterations (0: none)
    bf16: Literal["auto", "on", "off"] = "auto"  # bfloat16 autocast; auto: on CUDA only


class InferConfig(_Strict):
    score_threshold: float = Field(0.1, ge=0.0, le=1.0)
    pre_nms: int = Field(500, ge=1)
    nms_iou: float = Field(0.2, gt=0.0, le=1.0)  # BEV IoU of the boxes at t
    max_detections: int = Field(100, ge=1)


class DetectorConfig(_Strict):
    name: str
    seed: int = 0
    data: DataConfig = DataConfig()
    model: ModelConfig
    loss: LossConfig = LossConfig()
    train: TrainConfig = TrainConfig()
    infer: InferConfig = InferConfig()

    @model_validator(mode="after")
    def _weights(self) -> "DetectorConfig":
        boxes = self.model.head.tracklet_boxes
        if len(self.loss.loc_weights) < boxes:
            raise ValueError(f"'loss.loc_weights': needs {boxes} weights")
        cells, strides = self.data.grid_size, self.model.backbone_2d.strides
        stride = strides[0] * strides[1] * strides[2]
        if any(c % stride for c in cells):
            raise ValueError(f"'model.backbone_2d.strides': the {cells[0]}x{cells[1]} pillar grid must divide by {stride}")
        return self


# Training settings that do not change the weights (the loader's draws are seeded per sample, not per process).
NOT_WEIGHTS_TRAIN = ("workers", "log_every", "checkpoint_every", "eval_every")


def same_weights(a: DetectorConfig, b: DetectorConfig) -> bool:
    """Whether training with `a` and with `b` gives the same weights (they differ at most in `infer` and NOT_WEIGHTS_TRAIN)."""

    def decisive(config: DetectorConfig) -> dict:
        data = config.model_dump(mode="json")
        del data["infer"]
        data["train"] = {k: v for k, v in data["train"].items() if k not in NOT_WEIGHTS_TRAIN}
        return data

    return decisive(a) == decisive(b)


def parse_config(data: object, source: str = "config") -> DetectorConfig:
    """Validate a parsed config; raise `UserError` naming the first bad field."""
    return validate(DetectorConfig, data, source)


def load_config(path: str | Path) -> DetectorConfig:
    """Read and validate a detector config YAML file."""
    return parse_config(read_yaml(path, "config"), str(path))
