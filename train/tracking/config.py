"""A tracker as a config file (as SimpleTrack's): association, life cycle, motion model and split.

One YAML file per tracker (train/configs/tracking/), all run by the one `tracker.Tracker`: the
paper's 3D DIoU tracker with any of its modules, or the AB3DMOT baseline. Validated by pydantic: an
unknown key, a wrong type or range, or a module the chosen association cannot use is one `UserError`
line naming the field. The tracker
takes the validated `TrackerConfig` itself; each section is the config of the module that uses it
(`association.AssociationConfig`, `life_cycle.LifeCycleConfig`, `motion_model.MOTION_MODELS`).

Every number is bounded: thresholds are DIoU or IoU values, in [-1, 1]; frame counts at most
`life_cycle.MAX_TRACK_FRAMES`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import model_validator

from simgen.errors import UserError
from simgen.validation import Strict, read_yaml, validate
from train.config import Name
from train.tracking.association import AssociationConfig
from train.tracking.life_cycle import LifeCycleConfig
from train.tracking.motion_model import MotionModel


class TrackerConfig(Strict):
    name: Name  # the row of Table 2
    association: AssociationConfig
    life_cycle: LifeCycleConfig
    motion_model: MotionModel  # constant-velocity Kalman filter's variances
    split: bool  # the paper's split of fused tracklets (tracklet_diou only)
    output: Literal["tracklet", "kalman"] = "tracklet"  # a matched track's box: its tracklet's at t or the filter's

    @model_validator(mode="after")
    def _modules(self) -> TrackerConfig:
        if self.association.method == "iou_3d":
            for field, value in (("split", self.split), ("life_cycle.backfill", self.life_cycle.backfill)):
                if value:
                    raise ValueError(f"'{field}': needs association.method tracklet_diou")
            if not self.life_cycle.birth_death:
                raise ValueError("'life_cycle.birth_death': AB3DMOT (iou_3d) always has it")
        return self


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
