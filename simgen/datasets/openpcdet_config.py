"""OpenPCDet settings for an `openpcdet` dataset: the class map its evaluation needs and a custom-dataset YAML.

OpenPCDet's `CustomDataset` maps every label name through `MAP_CLASS_TO_KITTI` before KITTI's
evaluator runs (a name it does not list is a `KeyError`), and its `POINT_CLOUD_RANGE` must hold the
points: ours are in the pitch frame, centred on the centre spot. The range below covers the pitch
with a margin, in whole PointPillars cells (0.16 m) times 16, so every stride of the backbone divides
the grid.
"""

from __future__ import annotations

import math

import yaml

from simgen.vocab import OFFICIAL_CLASS, PITCH_LENGTH_M, PITCH_WIDTH_M, PLAYER_CLASS

PILLAR_M = 0.16  # PointPillars' usual cell
GRID_MULTIPLE = 16  # the backbone's strides (2, 2, 2) and the head's upsampling need a grid divisible by this
MARGIN_M = 2.0  # beyond the touchlines and goal lines
Z_RANGE_M = (-1.0, 3.0)  # one pillar from below the ground to above a jumping player
#: Officials ignored (the evaluator skips detections on a DontCare box), or scored as their own class in the
#: slot of a KITTI class the pitch has none of (KITTI's evaluator knows only its own class names).
OFFICIAL_AS = {"ignored": "DontCare", "own class": "Cyclist"}


def _half_extent(half_m: float) -> float:
    step = PILLAR_M * GRID_MULTIPLE
    return round(math.ceil((half_m + MARGIN_M) / step) * step, 2)


def point_cloud_range() -> list[float]:
    """[x_min, y_min, z_min, x_max, y_max, z_max], metres, pitch frame."""
    x, y = _half_extent(PITCH_LENGTH_M / 2), _half_extent(PITCH_WIDTH_M / 2)
    return [-x, -y, Z_RANGE_M[0], x, y, Z_RANGE_M[1]]


def class_map(officials: str = "ignored") -> dict[str, str]:
    """`MAP_CLASS_TO_KITTI`: our label names to KITTI's; `officials` is a key of OFFICIAL_AS."""
    return {PLAYER_CLASS: "Pedestrian", OFFICIAL_CLASS: OFFICIAL_AS[officials]}


def class_names(officials: str = "ignored") -> list[str]:
    """The model's `CLASS_NAMES` that go with `class_map(officials)`."""
    return [PLAYER_CLASS] if officials == "ignored" else [PLAYER_CLASS, OFFICIAL_CLASS]


def custom_dataset_config() -> dict:
    """OpenPCDet's custom dataset config (tools/cfgs/dataset_configs/), for the folder linked as data/custom."""
    features = ["x", "y", "z", "intensity"]  # the model's; the .npy files' have `lidar_unit` after them
    return {
        "DATASET": "CustomDataset",
        "DATA_PATH": "../data/custom",
        "POINT_CLOUD_RANGE": point_cloud_range(),
        "MAP_CLASS_TO_KITTI": class_map("ignored"),
        "DATA_SPLIT": {"train": "train", "test": "val"},
        "INFO_PATH": {"train": ["custom_infos_train.pkl"], "test": ["custom_infos_val.pkl"]},
        "POINT_FEATURE_ENCODING": {
            "encoding_type": "absolute_coordinates_encoding", "used_feature_list": features,
            "src_feature_list": [*features, "lidar_unit"],
        },
        "DATA_AUGMENTOR": {
            "DISABLE_AUG_LIST": ["placeholder"],
            "AUG_CONFIG_LIST": [  # the pitch is symmetric under both flips; a rotation would turn it out of the range
                {"NAME": "random_world_flip", "ALONG_AXIS_LIST": ["x", "y"]},
                {"NAME": "random_world_scaling", "WORLD_SCALE_RANGE": [0.95, 1.05]},
            ],
        },
        "DATA_PROCESSOR": [
            {"NAME": "mask_points_and_boxes_outside_range", "REMOVE_OUTSIDE_BOXES": True},
            {"NAME": "shuffle_points", "SHUFFLE_ENABLED": {"train": True, "test": False}},
            {
                "NAME": "transform_points_to_voxels",
                "VOXEL_SIZE": [PILLAR_M, PILLAR_M, Z_RANGE_M[1] - Z_RANGE_M[0]],
                "MAX_POINTS_PER_VOXEL": 32,
                "MAX_NUMBER_OF_VOXELS": {"train": 16000, "test": 40000},
            },
        ],
    }


def custom_dataset_yaml() -> str:
    return yaml.safe_dump(custom_dataset_config(), sort_keys=False, default_flow_style=None, width=100)


def card_lines() -> list[str]:
    """The dataset card's OpenPCDet section."""
    return [
        "Link this folder as OpenPCDet's `data/custom`, save the YAML below as",
        "`tools/cfgs/dataset_configs/simgen_custom.yaml`, then",
        "`python -m pcdet.datasets.custom.custom_dataset create_custom_infos "
        "tools/cfgs/dataset_configs/simgen_custom.yaml`",
        "(see simgen's docs/openpcdet.md for PointPillars).",
        "",
        "Class map (`MAP_CLASS_TO_KITTI`; OpenPCDet's evaluation raises `KeyError` on a name it does not list):",
        "",
        f"- officials ignored: model `CLASS_NAMES: {class_names('ignored')}`, "
        f"`MAP_CLASS_TO_KITTI: {class_map('ignored')}`",
        f"- officials as their own class: `CLASS_NAMES: {class_names('own class')}`, "
        f"`MAP_CLASS_TO_KITTI: {class_map('own class')}`",
        f"  (KITTI's evaluator knows only its own names: the `{OFFICIAL_AS['own class']}` rows are "
        "the officials' scores)",
        "",
        "```yaml",
        custom_dataset_yaml().rstrip(),
        "```",
    ]
