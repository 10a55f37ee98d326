"""A tracker as a config file (as SimpleTrack's): association, life cycle, motion model and split.

One YAML file per tracker (train/configs/tracking/): the paper's 3D DIoU tracker with any of its
modules, or the AB3DMOT baseline. Validated by pydantic: an unknown key, a wrong type or range, or
a module the chosen association cannot use is one `UserError` line naming the field.

Every number is bounded. Thresholds are DIoU or IoU values, in [-1, 1]; the association weights
sum to 1 so that they keep DIoU's scale. A track lives at most `MAX_TRACK_FRAMES` frames unmatched
or unconfirmed: with at most `train.config.MAX_DETECTIONS` (500) tracklets a frame, at most 500
tracks are matched and 500 x 100 dying at once, so a frame's affinity matrix stays under 500 x
50,500 entries (200 MB).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from simgen.errors import UserError
from simgen.validation import read_yaml, validate
from train.config import Name
from train.tracking.ab3dmot import Ab3dmot, Ab3dmotConfig
from train.tracking.clip import OnlineTracker
from train.tracking.diou_tracker import DiouTracker, DiouTrackerConfig
from train.tracking.motion_model import PLAYER_KALMAN, KalmanConfig

MOTION_MODELS = {"kalman_player": PLAYER_KALMAN, "kalman_ab3dmot": KalmanConfig()}
MAX_TRACK_FRAMES = 100  # 10 s at 10 Hz: 16 x the paper's 6 dying frames


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


Share = Annotated[float, Field(ge=0.0, le=1.0)]


class AssociationConfig(_Strict):
    """`tracklet_diou`: the paper's weighted 3D DIoU of a tracklet's boxes at t-2, t-1 and a
    trajectory's; `iou_3d`: AB3DMOT's 3D IoU of the boxes at t and the Kalman predictions."""

    method: Literal["tracklet_diou", "iou_3d"]
    lower_bound: float = Field(ge=-1.0, le=1.0)  # pairs below it never match (normal trajectories for DIoU)
    dying_lower_bound: float = Field(-0.5, ge=-1.0, le=1.0)  # tracklet_diou: for dying trajectories
    weights: tuple[Share, Share] = (0.4, 0.6)  # tracklet_diou: of the DIoU at t-2 and at t-1, summing to 1

    @model_validator(mode="after")
    def _sum(self) -> AssociationConfig:
        if abs(sum(self.weights) - 1.0) > 1e-6:
            raise ValueError(f"'association.weights': {self.weights[0]:g} + {self.weights[1]:g} is not 1")
        return self


class LifeCycleConfig(_Strict):
    birth_death: bool  # off (tracklet_diou only): every tracklet output at once, a miss ends a track
    min_hits: int = Field(3, ge=1, le=MAX_TRACK_FRAMES)  # matches before a new track is output
    # consecutive misses a confirmed track survives (dying frames)
    max_misses: int = Field(6, ge=0, le=MAX_TRACK_FRAMES)
    backfill: bool = False  # tracklet_diou: a confirmed track's first frames output from its tracklet
    output_dying: bool = True  # tracklet_diou: dying tracks output at their predicted box


class TrackerConfig(_Strict):
    name: Name  # the row of Table 2
    association: AssociationConfig
    life_cycle: LifeCycleConfig
    motion_model: Literal["kalman_player", "kalman_ab3dmot"]  # constant-velocity Kalman filter's variances
    split: bool  # the paper's split of fused tracklets (tracklet_diou only)

    @model_validator(mode="after")
    def _modules(self) -> TrackerConfig:
        if self.association.method == "iou_3d":
            for field, value in (("split", self.split), ("life_cycle.backfill", self.life_cycle.backfill)):
                if value:
                    raise ValueError(f"'{field}': needs association.method tracklet_diou")
            if not self.life_cycle.birth_death:
                raise ValueError("'life_cycle.birth_death': AB3DMOT (iou_3d) always has it")
        return self


def make_tracker(config: TrackerConfig) -> OnlineTracker:
    """A fresh tracker (one per clip) as the config says."""
    a, life, kalman = config.association, config.life_cycle, MOTION_MODELS[config.motion_model]
    if a.method == "iou_3d":
        return Ab3dmot(Ab3dmotConfig(a.lower_bound, life.min_hits, life.max_misses + 1, kalman))
    return DiouTracker(DiouTrackerConfig(
        weights=a.weights, normal_lower_bound=a.lower_bound, dying_lower_bound=a.dying_lower_bound,
        max_dying_frames=life.max_misses, min_hits=life.min_hits, birth_death=life.birth_death, split=config.split,
        output_dying=life.output_dying, backfill=life.backfill, kalman=kalman,
    ))


def load_tracker_config(path: str | Path) -> TrackerConfig:
    return validate(TrackerConfig, read_yaml(path, "tracker config"), str(path))


def load_tracker_configs(folder: str | Path) -> list[TrackerConfig]:
    """Every `*.yaml` in folder, in file-name order (the rows of Table 2)."""
    paths = sorted(Path(folder).glob("*.yaml"))
    if not paths:
        raise UserError(f"{folder}: no tracker configs (*.yaml)")
    configs = [load_tracker_config(p) for p in paths]
    names = [c.name for c in configs]
    if len(set(names)) < len(names):
        raise UserError(f"{folder}: two tracker configs share a name")
    return configs
