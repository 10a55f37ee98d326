"""The shipped tracker configs (train/configs/tracking/, the rows of Table 2) by name, and variants of them."""

from __future__ import annotations

from train.study.run import TRACKER_CONFIGS
from train.tracking.config import TrackerConfig, load_tracker_configs

AB3DMOT = "AB3DMOT"
DIOU = "3D DIoU"
BIRTH_DEATH = "3D DIoU + birth/death"
FULL_TRACKER = "3D DIoU + birth/death + split"  # the paper's full tracker: the last row of Table 2


def shipped_tracker(name: str, **changes: dict) -> TrackerConfig:
    """The shipped config of that name, with some fields of its sections changed (validated again):
    `shipped_tracker(FULL_TRACKER, life_cycle={"backfill": False})`."""
    config = next(c for c in load_tracker_configs(TRACKER_CONFIGS) if c.name == name)
    data = config.model_dump()
    for section, fields in changes.items():
        data[section] = {**data[section], **fields}
    return TrackerConfig.model_validate(data)
