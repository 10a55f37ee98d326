"""Hostile input for `simgen-train`, generated: detector configs, tracker configs, checkpoints and
argument sets for `fit`, `eval`, `detect` and `study`, each refused in one line with exit code 2
before anything is trained or allocated; the allocation bombs of issue 31 as real processes, their
peak memory measured; and the memory estimate that refuses what a machine cannot hold, against a
real training step.

The generated cases run in this process through `train.cli.main` (milliseconds each); the counts in
docs/reliability.md are the constants asserted here.
"""

from __future__ import annotations

import copy
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from simgen.errors import UserError
from simgen.validation import MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES
from tests.support import ROOT
from tests.support.detector import smoke_dataset, tiny_config
from tests.support.hostile import SETTINGS, assert_one_line_refusal, measured_process, refuse_generated, run_main
from train.checkpoint import FORMAT, VERSION, Checkpoint, save_checkpoint
from train.cli import main
from train.config import (
    MAX_ANCHORS,
    MAX_BATCH,
    MAX_CHANNELS,
    MAX_DETECTIONS,
    MAX_GRID_CELLS,
    MAX_ITERATIONS,
    MAX_LAYERS,
    MAX_LR,
    MAX_PRE_NMS,
    MAX_RANGE_M,
    MAX_SEED,
    MAX_STRIDE,
    MAX_WORKERS,
    MIN_PILLAR_M,
    load_config,
    parse_config,
)
from train.detector.model import Detector
from train.preflight import (
    MAX_SEEDS,
    NMS_BYTES_PER_PAIR,
    check_memory,
    check_resume,
    check_workers,
    cpu_cores,
    estimate_memory,
    parameter_counts,
    parse_seeds,
)
from train.tracking.life_cycle import MAX_TRACK_FRAMES

DETECTOR_CONFIGS = 300
TRACKER_CONFIGS = 100
CHECKPOINTS = 100
ARGUMENT_SETS = 150
MAX_PROCESS_BYTES = 1 << 30
MAX_PROCESS_SECONDS = 30.0
# Memory no machine has: a case needing more is refused wherever the tests run.
BEYOND_ANY_MACHINE = 4 << 40


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> dict[str, Path]:
    """A real dataset, tiny detector configs for `study --configs`, the real tracker configs, a valid
    checkpoint, and an empty folder for outputs that must stay empty."""
    dataset = smoke_dataset(tmp_path_factory.getbasetemp(), 6)
    root = tmp_path_factory.mktemp("train_hostile")
    configs = root / "configs"
    configs.mkdir()
    for method in ("single", "early", "late"):
        (configs / f"{method}.yaml").write_text(yaml.safe_dump(_tiny(method)))
    trackers = root / "trackers"
    shutil.copytree(ROOT / "train" / "configs" / "tracking", trackers)
    config = parse_config(_tiny("late"))
    checkpoint = root / "good.pt"
    save_checkpoint(checkpoint, Checkpoint(config, Detector(config).state_dict(), None, 1))
    (root / "out").mkdir()
    (root / "datasets").mkdir()
    (root / "a_file").write_text("not a folder\n")
    return {"dataset": dataset, "root": root, "configs": configs, "trackers": trackers, "checkpoint": checkpoint,
            "out": root / "out", "datasets": root / "datasets", "a_file": root / "a_file"}


def _tiny(method: str) -> dict:
    data = tiny_config(method).model_dump(mode="json")
    data["train"].update(iterations=1, workers=0)
    return data


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# --- values a field refuses ---------------------------------------------------------------------

LETTERS = st.text(alphabet="qwxz", min_size=1, max_size=6)  # no number, bool or null that YAML or pydantic would read
WRONG_TYPE = st.one_of(LETTERS, st.lists(st.integers(), min_size=1, max_size=3), st.just({"k": 1}),
                       st.just(float("nan")), st.just(float("inf")), st.just(float("-inf")))


def _outside(lo: float, hi: float, integer: bool, strict_low: bool = False):
    """Values a field bounded to [lo, hi] (or (lo, hi] with `strict_low`) refuses."""
    below = st.floats(min_value=0 if strict_low else 1e-3, max_value=1e12).map(lambda d: lo - d)
    above = st.floats(min_value=1e-3, max_value=1e12).map(lambda d: hi + d)
    if integer:
        below, above = below.map(lambda v: math.ceil(v) - 1), above.map(lambda v: int(v) + 1)
        fractional = st.integers(int(lo), int(min(hi, lo + 1000)) - 1).map(lambda v: v + 0.5)
        return st.one_of(below, above, fractional, WRONG_TYPE, st.none())
    return st.one_of(below, above, WRONG_TYPE, st.none())


# (path, low, high, integer, low excluded)
NUMBERS = [
    (("data", "pillar_size_m"), MIN_PILLAR_M, 2 * MAX_RANGE_M, False, False),
    (("data", "augment", "rotation_rad"), 0.0, 3.1416, False, False),
    (("model", "pillar_encoder", "channels"), 1, MAX_CHANNELS, True, False),
    (("model", "head", "anchor", "z_m"), -MAX_RANGE_M, MAX_RANGE_M, False, False),
    (("model", "head", "anchor", "match_iou"), 0.0, 1.0, False, True),
    (("model", "head", "anchor", "unmatch_iou"), 0.0, 1.0, False, False),
    (("model", "head", "dir_offset_rad"), -6.2832, 6.2832, False, False),
    (("loss", "cls_weight"), 0.0, 1000.0, False, False),
    (("loss", "dir_weight"), 0.0, 1000.0, False, False),
    (("loss", "focal_alpha"), 0.0, 1.0, False, False),
    (("loss", "focal_gamma"), 0.0, 10.0, False, False),
    (("loss", "smooth_l1_beta"), 0.0, 10.0, False, True),
    (("train", "iterations"), 1, MAX_ITERATIONS, True, False),
    (("train", "batch_size"), 1, MAX_BATCH, True, False),
    (("train", "lr"), 0.0, MAX_LR, False, True),
    (("train", "weight_decay"), 0.0, 1.0, False, False),
    (("train", "grad_clip"), 0.0, 1e6, False, True),
    (("train", "workers"), 0, MAX_WORKERS, True, False),
    (("train", "checkpoint_every"), 1, MAX_ITERATIONS, True, False),
    (("train", "log_every"), 1, MAX_ITERATIONS, True, False),
    (("train", "eval_every"), 0, MAX_ITERATIONS, True, False),
    (("infer", "score_threshold"), 0.0, 1.0, False, False),
    (("infer", "pre_nms"), 1, MAX_PRE_NMS, True, False),
    (("infer", "nms_iou"), 0.0, 1.0, False, True),
    (("infer", "max_detections"), 1, MAX_DETECTIONS, True, False),
    (("seed",), 0, MAX_SEED, True, False),
]
# (path, length, low, high, integer, low excluded): each element bounded
TUPLES = [
    (("data", "point_range_m"), 6, -MAX_RANGE_M, MAX_RANGE_M, False, False),
    (("model", "backbone_2d", "layers"), 3, 1, MAX_LAYERS, True, False),
    (("model", "backbone_2d", "strides"), 3, 1, MAX_STRIDE, True, False),
    (("model", "backbone_2d", "channels"), 3, 1, MAX_CHANNELS, True, False),
    (("model", "backbone_2d", "upsample_strides"), 3, 1, MAX_STRIDE, True, False),
    (("model", "backbone_2d", "upsample_channels"), 3, 1, MAX_CHANNELS, True, False),
    (("model", "head", "anchor", "size_m"), 3, 0.0, 20.0, False, True),
    (("model", "head", "anchor", "yaws_rad"), 2, -6.2832, 6.2832, False, False),
    (("loss", "loc_weights"), 3, 0.0, 1000.0, False, False),
]
LITERALS = [
    ("model", "fusion", "name"),
    ("model", "head", "tracklet_boxes"),
    ("model", "head", "name"),
    ("model", "head", "box_coder", "name"),
    ("model", "pillar_encoder", "name"),
    ("model", "backbone_2d", "name"),
    ("train", "bf16"),
]
NAME_BAD = st.one_of(
    st.just(""),
    st.text(min_size=65, max_size=80, alphabet="ab"),
    st.sampled_from(["a\nb", "x\x00y", "\x1b[31m"]),
    st.integers(),
    st.lists(LETTERS, min_size=1),
    st.none(),
)


def _set(data: dict, path: tuple, value: object) -> None:
    for key in path[:-1]:
        data = data.setdefault(key, {})
    data[path[-1]] = value


def _get(data: dict, path: tuple) -> object:
    for key in path:
        data = data[key]
    return data


@st.composite
def _detector_case(draw) -> tuple[str, dict | bytes]:
    """(kind, a detector config document or the bytes of one) that must be refused."""
    method = draw(st.sampled_from(["single", "early", "late"]))
    data = _tiny(method)
    kind = draw(
        st.sampled_from(
            [
                "number",
                "tuple element",
                "tuple length",
                "literal",
                "name",
                "classes",
                "unknown key",
                "missing section",
                "section type",
                "grid cells",
                "anchors",
                "grid divisibility",
                "upsampling sizes",
                "range order",
                "whole pillars",
                "augment scale",
                "anchor thresholds",
                "detections beyond pre_nms",
                "box weights",
                "single-frame tracklet",
                "memory: batch",
                "memory: one sample",
                "workers beyond cores",
                "yaml",
            ]
        )
    )
    if kind == "number":
        path, lo, hi, integer, strict = draw(st.sampled_from(NUMBERS))
        _set(data, path, draw(_outside(lo, hi, integer, strict)))
        return f"number {'.'.join(path)}", data
    if kind == "tuple element":
        path, length, lo, hi, integer, strict = draw(st.sampled_from(TUPLES))
        values = list(_get(data, path))[:length] or [lo] * length
        values[draw(st.integers(0, len(values) - 1))] = draw(
            _outside(lo, hi, integer, strict).filter(lambda v: v is not None)
        )
        _set(data, path, values)
        return f"element {'.'.join(path)}", data
    if kind == "tuple length":
        path, length, lo, *_ = draw(
            st.sampled_from(
                [t for t in TUPLES if t[0] not in (("model", "head", "anchor", "yaws_rad"), ("loss", "loc_weights"))]
            )
        )
        _set(data, path, [lo + 1] * draw(st.integers(0, 9).filter(lambda n: n != length)))
        return "tuple length", data
    if kind == "literal":
        path = draw(st.sampled_from(LITERALS))
        _set(data, path, draw(st.one_of(LETTERS, st.integers(4, 100), st.none())))
        return "literal", data
    if kind == "name":
        data["name"] = draw(NAME_BAD)
        return "name", data
    if kind == "classes":
        data["data"]["classes"] = draw(
            st.one_of(
                st.just([]),
                st.lists(st.just("Pedestrian"), min_size=17, max_size=30),
                st.lists(NAME_BAD.filter(lambda v: v is not None), min_size=1, max_size=3),
            )
        )
        return "classes", data
    if kind == "unknown key":
        section = draw(
            st.sampled_from([(), ("data",), ("model",), ("model", "head"), ("train",), ("infer",), ("loss",)])
        )
        target = _get(data, section) if section else data
        target[draw(LETTERS.map(lambda s: "unknown_" + s))] = 1
        return kind, data
    if kind == "missing section":
        del data[draw(st.sampled_from(["model", "name"]))]
        return kind, data
    if kind == "section type":
        data[draw(st.sampled_from(["data", "model", "train", "infer", "loss"]))] = draw(
            st.one_of(LETTERS, st.integers(), st.lists(st.integers(), min_size=1))
        )
        return kind, data
    if kind == "grid cells":  # range / pillar size beyond MAX_GRID_CELLS
        size = draw(st.floats(MIN_PILLAR_M, 0.5))
        cells = draw(st.integers(math.isqrt(MAX_GRID_CELLS) + 1, int(2 * MAX_RANGE_M / size)))
        half = cells * size / 2
        data["data"].update(point_range_m=[-half, -half, -0.1, half, half, 2.5], pillar_size_m=size)
        return kind, data
    if kind == "anchors":  # the finest grid at output stride 1, more yaws than MAX_ANCHORS allows
        yaws = draw(st.integers(3, 16))
        data["data"].update(point_range_m=[-512.0, -512.0, -0.1, 512.0, 512.0, 2.5], pillar_size_m=0.25)
        data["model"]["backbone_2d"].update(strides=[1, 1, 1], upsample_strides=[1, 1, 1])
        data["model"]["head"]["anchor"]["yaws_rad"] = [0.1 * k for k in range(yaws)]
        assert 4096 * 4096 * yaws > MAX_ANCHORS
        return kind, data
    if kind == "grid divisibility":
        stride = draw(st.sampled_from([3, 5, 6, 7]))
        data["model"]["backbone_2d"].update(strides=[stride, 1, 1], upsample_strides=[1, 1, 1])
        return kind, data
    if kind == "upsampling sizes":
        ups = draw(st.sampled_from([[1, 1, 1], [1, 2, 2], [2, 2, 4]]))
        data["model"]["backbone_2d"].update(strides=[2, 2, 2], upsample_strides=ups)
        return kind, data
    if kind == "range order":
        axis = draw(st.integers(0, 2))
        low = draw(st.floats(-100, 100))
        bounds = data["data"]["point_range_m"]
        bounds[axis], bounds[axis + 3] = low, low - draw(st.floats(0, 50))
        return kind, data
    if kind == "whole pillars":
        data["data"]["pillar_size_m"] = draw(st.sampled_from([0.3, 0.33, 0.7, 0.15, 0.45]))
        return kind, data
    if kind == "augment scale":
        data["data"]["augment"]["scale"] = draw(
            st.one_of(
                st.tuples(st.floats(0.5, 2), st.floats(0.01, 0.49)).map(list),
                st.tuples(st.floats(-5, 0), st.floats(0.5, 2)).map(list),
                st.tuples(st.floats(0.5, 2), st.floats(10.01, 1e6)).map(list),
            )
        )
        return kind, data
    if kind == "anchor thresholds":
        match = draw(st.floats(0.05, 0.95))
        data["model"]["head"]["anchor"].update(match_iou=match, unmatch_iou=draw(st.floats(match + 0.01, 1.0)))
        return kind, data
    if kind == "detections beyond pre_nms":
        pre = draw(st.integers(1, MAX_DETECTIONS - 1))
        data["infer"].update(pre_nms=pre, max_detections=draw(st.integers(pre + 1, MAX_DETECTIONS)))
        return kind, data
    if kind == "box weights":
        data["model"]["fusion"]["name"], data["model"]["head"]["tracklet_boxes"] = "late", 3
        data["loss"]["loc_weights"] = [1.0] * draw(st.integers(1, 2))
        return kind, data
    if kind == "single-frame tracklet":
        data["model"]["fusion"]["name"], data["model"]["head"]["tracklet_boxes"] = "single", 3
        return kind, data
    if kind == "memory: batch":  # the paper's late model: about 5 GiB a sample
        data = load_config(ROOT / "train" / "configs" / "paper" / "late.yaml").model_dump(mode="json")
        data["train"].update(workers=0, batch_size=draw(st.integers(_beyond_any_machine(data), MAX_BATCH)))
        return kind, data
    if kind == "memory: one sample":  # the finest grid of the widest maps
        data = _widest(_tiny("late"), draw(st.sampled_from([0.125, 0.25, 0.5])))
        assert _one_sample(data, training=True) > BEYOND_ANY_MACHINE
        return kind, data
    if kind == "workers beyond cores":
        data["train"]["workers"] = draw(st.integers(cpu_cores() + 1, max(MAX_WORKERS, cpu_cores() + 1)))
        return kind, data
    return draw(_yaml_case())


def _widest(data: dict, pillar_size_m: float) -> dict:
    """The config at 4,096 x 4,096 pillars of `pillar_size_m`, every map 1,024 channels wide, 32 layers a block."""
    half = 4096 * pillar_size_m / 2
    data["data"].update(point_range_m=[-half, -half, -0.1, half, half, 2.5], pillar_size_m=pillar_size_m)
    data["model"]["pillar_encoder"]["channels"] = MAX_CHANNELS
    data["model"]["backbone_2d"].update(channels=[MAX_CHANNELS] * 3, layers=[MAX_LAYERS] * 3)
    return data


def _one_sample(data: dict, training: bool) -> int:
    estimate = estimate_memory(parse_config(data), 30_000, training=training, host=True)
    return estimate.fixed + estimate.per_sample


def _beyond_any_machine(data: dict) -> int:
    """Smallest batch of this config whose training needs more than BEYOND_ANY_MACHINE."""
    estimate = estimate_memory(parse_config(data), 30_000, training=True, host=True)
    batch = (BEYOND_ANY_MACHINE - estimate.fixed - estimate.nms) // estimate.per_sample + 1
    assert batch <= MAX_BATCH, batch
    return batch


@st.composite
def _yaml_case(draw) -> tuple[str, bytes]:
    """Documents the YAML reader refuses whatever the schema."""
    base = yaml.safe_dump(_tiny("late"))
    kind = draw(
        st.sampled_from(["laughs", "deep", "duplicate", "oversize", "malformed", "not a mapping", "tag", "not UTF-8"])
    )
    if kind == "laughs":
        width = draw(st.integers(4, 12))
        levels = next(n for n in range(1, 40) if width**n > MAX_YAML_NODES) + draw(st.integers(0, 2))
        lines = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
        lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]" for i in range(1, levels)]
        text = base + "\n".join(lines) + "\n"
    elif kind == "deep":
        depth = draw(st.integers(MAX_YAML_DEPTH + 1, 20_000))
        text = base + "extra: " + "[" * depth + "]" * depth + "\n"
    elif kind == "duplicate":
        text = base + draw(st.sampled_from(["seed: 4\n", "name: again\n"]))
    elif kind == "oversize":
        text = base + "description: '" + "x" * (MAX_YAML_BYTES + draw(st.integers(1, 4096))) + "'\n"
    elif kind == "malformed":
        text = base + draw(st.sampled_from(["model: [1, 2\n", "name: 'open\n", "\tseed: 1\n", "seed: 1: 2\n"]))
    elif kind == "not a mapping":
        text = draw(st.sampled_from(["- a\n- b\n", "just a string\n", "42\n", "", "~\n", "[]\n"]))
    elif kind == "tag":
        text = base + draw(st.sampled_from(["x: !!python/object/apply:os.system ['true']\n", "x: !custom 1\n"]))
    else:
        position = draw(st.integers(0, len(base)))
        return f"yaml: {kind}", base[:position].encode() + b"\xff" + base[position:].encode()
    return f"yaml: {kind}", text.encode()


def _write(path: Path, document: dict | bytes) -> None:
    path.write_bytes(document if isinstance(document, bytes) else yaml.safe_dump(document, allow_unicode=True).encode())


def _check_generated(world, strategy, examples: int, run_case) -> dict[str, int]:
    """Every case `strategy` draws through `run_case` (-> CLI arguments): refused in one line, in bounded CPU time
    and memory (tests.support.hostile.refuse_generated), nothing written to the outputs."""

    def prepare(case):
        kind, arguments = run_case(case)
        return kind, case, lambda: run_main(main, *arguments)

    kinds = refuse_generated(strategy, examples, prepare, "cases")
    assert _listing(world["out"]) == _listing(world["datasets"]) == []  # nothing written, not even an output folder
    return kinds


@pytest.mark.engine  # the commands read a dataset generated with the engine
def test_generated_hostile_detector_configs_are_refused_in_one_line(world):
    config = world["root"] / "hostile.yaml"

    def run_case(case):
        kind, document = case
        _write(config, document)
        return kind, ["fit", config, "--dataset", world["dataset"], "-o", world["out"] / "run", "--quiet",
                      "--device", "cpu"]

    kinds = _check_generated(world, _detector_case(), DETECTOR_CONFIGS, run_case)
    config.unlink()
    assert sum(kinds.values()) >= DETECTOR_CONFIGS and len(kinds) >= 30, sorted(kinds)


# --- tracker configs ------------------------------------------------------------------------------

TRACKER = {
    "name": "hostile",
    "association": {"method": "tracklet_diou", "lower_bound": -0.125, "dying_lower_bound": -0.5, "weights": [0.4, 0.6]},
    "life_cycle": {"birth_death": True, "min_hits": 3, "max_misses": 6, "backfill": True, "output_dying": True},
    "motion_model": "kalman_player",
    "split": True,
}
TRACKER_NUMBERS = [
    (("association", "lower_bound"), -1.0, 1.0, False),
    (("association", "dying_lower_bound"), -1.0, 1.0, False),
    (("life_cycle", "min_hits"), 1, MAX_TRACK_FRAMES, True),
    (("life_cycle", "max_misses"), 0, MAX_TRACK_FRAMES, True),
    (("life_cycle", "tentative_max_misses"), 0, MAX_TRACK_FRAMES, True),
]


@st.composite
def _tracker_case(draw) -> tuple[str, object]:
    """(kind, what to put in the --trackers folder): a tracker config document, or a folder problem."""
    data = copy.deepcopy(TRACKER)
    kind = draw(st.sampled_from(["number", "weights", "literal", "name", "unknown key", "missing key", "iou_3d modules",
                                 "duplicate name", "folder", "yaml"]))
    if kind == "number":
        path, lo, hi, integer = draw(st.sampled_from(TRACKER_NUMBERS))
        _set(data, path, draw(_outside(lo, hi, integer)))
        return f"number {'.'.join(path)}", data
    if kind == "weights":
        data["association"]["weights"] = draw(st.one_of(
            st.tuples(st.floats(0, 1), st.floats(0, 1)).filter(lambda w: abs(sum(w) - 1) > 1e-5).map(list),
            st.tuples(_outside(0, 1, False).filter(lambda v: v is not None), st.floats(0, 1)).map(list),
            st.lists(st.floats(0, 1), max_size=5).filter(lambda w: len(w) != 2), WRONG_TYPE))
        return kind, data
    if kind == "literal":
        path = draw(
            st.sampled_from([("association", "method"), ("motion_model",), ("split",), ("life_cycle", "birth_death")])
        )
        _set(data, path, draw(st.one_of(LETTERS, st.integers(2, 100), st.none())))
        return kind, data
    if kind == "name":
        data["name"] = draw(NAME_BAD)
        return kind, data
    if kind == "unknown key":
        section = draw(st.sampled_from([(), ("association",), ("life_cycle",)]))
        (_get(data, section) if section else data)[draw(LETTERS.map(lambda s: "unknown_" + s))] = 1
        return kind, data
    if kind == "missing key":
        path = draw(
            st.sampled_from(
                [
                    ("name",),
                    ("association",),
                    ("life_cycle",),
                    ("motion_model",),
                    ("split",),
                    ("association", "method"),
                    ("association", "lower_bound"),
                    ("life_cycle", "birth_death"),
                ]
            )
        )
        del (_get(data, path[:-1]) if len(path) > 1 else data)[path[-1]]
        return kind, data
    if kind == "iou_3d modules":
        data["association"]["method"] = "iou_3d"
        data["life_cycle"]["backfill"] = False
        which = draw(st.sampled_from(["split", "backfill", "no birth_death"]))
        data["split"] = which == "split"
        data["life_cycle"]["backfill"] = which == "backfill"
        data["life_cycle"]["birth_death"] = which != "no birth_death"
        return kind, data
    if kind == "duplicate name":
        data["name"] = "3D DIoU"  # as train/configs/tracking/2_diou.yaml
        return kind, data
    if kind == "folder":
        return kind, draw(st.sampled_from(["empty", "missing", "a file"]))
    return draw(_yaml_case())


@pytest.mark.engine  # the commands read a dataset generated with the engine
def test_generated_hostile_tracker_configs_are_refused_in_one_line(world):
    """Through `study --trackers`: refused before the study generates or trains anything."""
    folder, hostile = world["root"] / "trackers_hostile", world["root"] / "trackers_hostile" / "9_hostile.yaml"

    def run_case(case):
        kind, document = case
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(world["trackers"], folder)
        where = folder
        if document == "empty":
            shutil.rmtree(folder)
            folder.mkdir()
        elif document == "missing":
            where = folder / "absent"
        elif document == "a file":
            where = world["a_file"]
        else:
            _write(hostile, document)
        return kind, [
            "study",
            ROOT / "scenarios" / "smoke.yaml",
            "-o",
            world["out"] / "study",
            "--datasets",
            world["datasets"],
            "--configs",
            world["configs"],
            "--trackers",
            where,
            "--iterations",
            1,
            "--workers",
            0,
            "--quiet",
            "--device",
            "cpu",
        ]

    try:
        kinds = _check_generated(world, _tracker_case(), TRACKER_CONFIGS, run_case)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    assert sum(kinds.values()) >= TRACKER_CONFIGS and len(kinds) >= 15, sorted(kinds)


# --- checkpoints ------------------------------------------------------------------------------------


@st.composite
def _checkpoint_case(draw) -> tuple[str, object]:
    """(kind, a checkpoint payload to torch.save, or bytes) that `eval` and `detect` must refuse."""
    config = parse_config(_tiny("late"))
    state = Detector(config).state_dict() if draw(st.booleans()) else {"w": torch.zeros(1)}
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "config": _tiny("late"),
        "model": state,
        "optimizer": None,
        "iteration": 1,
    }
    kind = draw(st.sampled_from(["config", "format", "version", "model", "iteration", "optimizer", "missing", "payload",
                                 "bytes", "weights", "memory: inference"]))
    kind = f"{draw(st.sampled_from(['eval', 'detect']))} {kind}"
    if kind.endswith(" config"):
        sub, document = draw(_detector_case().filter(lambda c: isinstance(c[1], dict) and not c[0].startswith(("memory",
                                                                                                               "workers"))))
        payload["config"] = document
        return f"{kind}: {sub}", payload
    if kind.endswith(" format"):
        payload["format"] = draw(st.one_of(LETTERS, st.integers(), st.none()))
    elif kind.endswith(" version"):
        payload["version"] = draw(st.integers().filter(lambda v: v != VERSION) | LETTERS)
    elif kind.endswith(" model"):
        payload["model"] = draw(st.sampled_from([[1, 2], "weights", {"w": 1.5}, {1: torch.zeros(1)}, None]))
    elif kind.endswith(" iteration"):
        payload["iteration"] = draw(
            st.one_of(st.integers(max_value=-1), LETTERS, st.just(1.5), st.none(), st.just(True))
        )
    elif kind.endswith(" optimizer"):
        payload["optimizer"] = draw(st.one_of(LETTERS, st.lists(st.integers(), min_size=1), st.integers()))
    elif kind.endswith(" missing"):
        del payload[draw(st.sampled_from(["format", "version", "config", "model", "iteration"]))]
    elif kind.endswith(" payload"):
        payload = draw(st.sampled_from([[1, 2, 3], "checkpoint", 42, None, {"format": FORMAT}]))
    elif kind.endswith(" bytes"):
        return kind, draw(
            st.sampled_from([b"", b"\x80\x02not a checkpoint", b"PK\x03\x04" + b"\0" * 100, b"\x00" * 1000])
        )
    elif kind.endswith(" weights"):  # a well-formed checkpoint whose weights are another model's
        other = parse_config(_tiny(draw(st.sampled_from(["single", "early"]))))
        payload["model"] = Detector(other).state_dict()
    else:  # a config whose inference no machine holds
        payload["config"] = _widest(_tiny("late"), draw(st.sampled_from([0.125, 0.25, 0.5])))
        assert _one_sample(payload["config"], training=False) > BEYOND_ANY_MACHINE
    return kind, payload


@pytest.mark.engine  # the commands read a dataset generated with the engine
def test_generated_hostile_checkpoints_are_refused_in_one_line(world):
    checkpoint = world["root"] / "hostile.pt"

    def run_case(case):
        kind, payload = case
        if isinstance(payload, bytes):
            checkpoint.write_bytes(payload)
        else:
            torch.save(payload, checkpoint)
        command = kind.split()[0]
        return kind, [command, checkpoint, "--dataset", world["dataset"], "-o", world["out"] / "eval", "--split", "all",
                      "--quiet", "--device", "cpu"]

    kinds = _check_generated(world, _checkpoint_case(), CHECKPOINTS, run_case)
    checkpoint.unlink()
    assert sum(kinds.values()) >= CHECKPOINTS and len(kinds) >= 20, sorted(kinds)


# --- argument sets ----------------------------------------------------------------------------------

BAD_COUNT = st.one_of(st.sampled_from(["x", "1.5", "1e3", "", "--", "0x10", "٣", "1_000", "9" * 50]),
                      st.integers(max_value=-1).map(str))


@st.composite
def _argument_case(draw) -> tuple[str, list]:
    """(kind, arguments with placeholders) that must be refused."""
    command = draw(st.sampled_from(["fit", "eval", "detect", "study"]))
    kind = draw(
        st.sampled_from(
            [
                "count",
                "dataset",
                "output",
                "device",
                "missing option",
                "unknown option",
                "config file",
                "checkpoint file",
                "split",
                "models",
                "scenario",
                "configs folder",
                "preset",
            ]
        )
    )
    if command == "fit":
        args = ["fit", "{configs}/late.yaml", "--dataset", "{dataset}", "-o", "{out}/fit", "--quiet", "--device", "cpu"]
    elif command in ("eval", "detect"):
        args = [
            command,
            "{checkpoint}",
            "--dataset",
            "{dataset}",
            "-o",
            "{out}/eval",
            "--split",
            "all",
            "--quiet",
            "--device",
            "cpu",
        ]
    else:
        args = [
            "study",
            str(ROOT / "scenarios" / "smoke.yaml"),
            "-o",
            "{out}/study",
            "--datasets",
            "{datasets}",
            "--configs",
            "{configs}",
            "--quiet",
            "--device",
            "cpu",
        ]
    if kind == "count" and command in ("fit", "study"):
        option = draw(st.sampled_from(["--iterations", "--workers"] + (["--seed"] if command == "study" else [])))
        high = {"--iterations": MAX_ITERATIONS, "--workers": MAX_WORKERS, "--seed": MAX_SEED}[option]
        value = draw(
            st.one_of(
                BAD_COUNT,
                st.integers(high + 1, 10**30).map(str),
                *([st.just("0")] if option == "--iterations" else []),
                *([st.integers(cpu_cores() + 1, MAX_WORKERS).map(str)] if option == "--workers" else []),
            )
        )
        return f"{command} {option}", args + [option, value]
    if kind == "dataset" and command != "study":
        at = args.index("--dataset") + 1
        args[at] = draw(st.sampled_from(["/nonexistent/ds", "/etc", "/dev/zero", "{a_file}", "{datasets}", "{out}"]))
        return f"{command} --dataset", args
    if kind == "output":
        at = args.index("-o") + 1
        args[at] = draw(st.sampled_from(["{a_file}", "{a_file}/below", "/dev/null"]))
        return f"{command} -o", args
    if kind == "device":
        devices = ["gpu", "tpu", "", "cuda:0"] + ([] if torch.cuda.is_available() else ["cuda"])
        args[args.index("--device") + 1] = draw(st.sampled_from(devices))
        return f"{command} --device", args
    if kind == "missing option":
        option = draw(st.sampled_from(["-o", "--dataset"] if command != "study" else ["-o"]))
        at = args.index(option)
        return f"{command} missing {option}", args[:at] + args[at + 2:]
    if kind == "unknown option":
        return f"{command} unknown option", args + [draw(LETTERS.map(lambda s: "--unknown-" + s))]
    if kind == "config file" and command == "fit":
        args[1] = draw(st.sampled_from(["/nonexistent.yaml", "/dev/zero", "/etc", "{checkpoint}", "{a_file}"]))
        return "fit config file", args
    if kind == "checkpoint file" and command in ("eval", "detect"):
        args[1] = draw(st.sampled_from(["/nonexistent.pt", "/dev/zero", "/etc", "{a_file}", "{configs}/late.yaml"]))
        return f"{command} checkpoint file", args
    if kind == "split" and command in ("eval", "detect"):
        args[args.index("--split") + 1] = draw(st.sampled_from(["test", "", "TRAIN", "../val"]))
        return f"{command} --split", args
    if command != "study":
        return f"{command} unknown option", args + ["--bogus"]
    if kind == "models":
        return "study --models", args + [
            "--models",
            draw(st.sampled_from(["single", "early", "late,bogus", "", ",", "late,late2"])),
        ]
    if kind == "scenario":
        args[1] = draw(st.sampled_from(["/nonexistent.yaml", "/dev/zero", "{a_file}", "{configs}/late.yaml"]))
        return "study scenario", args
    if kind == "configs folder":
        args[args.index("--configs") + 1] = draw(st.sampled_from(["/nonexistent", "{trackers}", "{a_file}"]))
        return "study --configs", args
    if kind == "preset":
        # with a scenario: refused
        return "study --preset", args + ["--preset", draw(st.sampled_from(["paper", "bogus"]))]
    return "study neither scenario nor preset", args[:1] + args[2:]


@pytest.mark.engine  # the commands read a dataset generated with the engine
def test_generated_hostile_arguments_are_refused_in_one_line(world):
    places = {k: str(v) for k, v in world.items()}

    def run_case(case):
        kind, arguments = case
        return kind, [a.format(**places) for a in arguments]

    kinds = _check_generated(world, _argument_case(), ARGUMENT_SETS, run_case)
    assert sum(kinds.values()) >= ARGUMENT_SETS and len(kinds) >= 30, sorted(kinds)


# --- the allocation bombs, as real processes --------------------------------------------------------


@pytest.mark.engine
@pytest.mark.parametrize("edits, options, field", [
    ({("model", "pillar_encoder", "channels"): 100_000_000}, [], "'model.pillar_encoder.channels'"),
    ({("data", "pillar_size_m"): 0.0001}, [], "'data.pillar_size_m'"),
    ({("data", "point_range_m"): [-1e9, -1e9, -0.1, 1e9, 1e9, 2.5]}, [], "'data.point_range_m.0'"),
    ({("train", "batch_size"): 100_000}, [], "'train.batch_size'"),
    ({("train", "batch_size"): 1000}, [], "'train.batch_size'"),  # within the static bound: the memory check refuses it
    # 3,200 x 3,200 pillars: a sample needs over 50 GiB
    ({("data", "pillar_size_m"): 0.025}, [], "'data.pillar_size_m'"),
    ({}, ["--iterations", "-5"], "--iterations"),
    ({}, ["--workers", "100000"], "--workers"),
])
def test_allocation_bombs_in_real_processes(world, tmp_path, edits, options, field):
    """Issue 31's cases on train/configs/late.yaml: exit 2, one line naming the field, under 1 GiB and 30 s."""
    data = load_config(ROOT / "train" / "configs" / "late.yaml").model_dump(mode="json")
    for path, value in edits.items():
        _set(data, path, value)
    config = tmp_path / "late.yaml"
    config.write_text(yaml.safe_dump(data))
    code, out, err, peak, seconds = measured_process("train.cli", "fit", config, "--dataset", world["dataset"], "-o",
                                                     tmp_path / "run", *(options or ["--iterations", "1"]), "--quiet",
                                                     "--device", "cpu")
    assert_one_line_refusal(code, out, err, (edits, options))
    assert field in err, err
    assert peak < MAX_PROCESS_BYTES and seconds < MAX_PROCESS_SECONDS, (edits, options, peak, seconds)
    assert not (tmp_path / "run").exists()


# --- the memory estimate, the machine's cores, resuming, seeds -------------------------------------


@pytest.mark.parametrize("path", ["late", "single", "early", "paper/late", "paper/early", "paper/single"])
def test_parameter_counts_are_the_models(path):
    config = load_config(ROOT / "train" / "configs" / f"{path}.yaml")
    model = Detector(config)
    for part, count in parameter_counts(config).items():
        module = getattr(model, part)
        stats = sum(b.numel() for name, b in module.named_buffers() if "running" in name)
        assert count == sum(p.numel() for p in module.parameters()) + stats, part


MEASURE = """
import ctypes, gc, json, sys, threading, time
import torch
from train.config import parse_config
from train.data import SampleSet, loader
from train.detector.losses import detection_loss
from train.detector.model import build_detector


def anonymous() -> int:
    # resident anonymous memory: what the process allocated, whatever the kernel does with its file pages
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) * 1024 for line in status if line.startswith("RssAnon:"))


config, dataset = parse_config(json.loads(sys.argv[1])), sys.argv[2]
reading = SampleSet(dataset, "train", config)
for i in range(len(reading)):
    reading[i]  # every sample read once: the reader's own memory is in the baseline
gc.collect()
ctypes.CDLL("libc.so.6").malloc_trim(0)
before, peak, done = anonymous(), [0], threading.Event()


def watch() -> None:
    while not done.is_set():
        peak[0] = max(peak[0], anonymous())
        time.sleep(0.0005)


watcher = threading.Thread(target=watch)
watcher.start()
model = build_detector(config).train()
draws = config.train.iterations * config.train.batch_size
samples = SampleSet(dataset, "train", config, draws=draws, assign=model.head.assigner)
optimizer = torch.optim.AdamW(model.parameters(), lr=1e-3)
for batch in loader(samples, config.train.batch_size, 0, model.head.assigner.collate):
    loss = detection_loss(model(batch).float(), batch.targets, config.loss).total
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
done.set()
watcher.join()
print(peak[0] - before)
"""


def _sized(method: str, channels: int, pillar_size_m: float = 0.25, batch: int = 1) -> dict:
    """A tiny config with every map `channels` wide, one layer a block, at a pillar size."""
    data = _tiny(method)
    data["data"]["pillar_size_m"] = pillar_size_m
    data["model"]["pillar_encoder"]["channels"] = channels
    data["model"]["backbone_2d"].update(layers=[1, 1, 1], channels=[channels] * 3, upsample_channels=[channels] * 3)
    data["train"].update(iterations=2, batch_size=batch)
    return data


@pytest.mark.engine
@pytest.mark.parametrize("data, tight", [
    (_sized("single", 1), False),  # the least a model can be: torch's own memory dominates
    (_sized("late", 8, 0.125), False),
    (_sized("single", 64, 0.125, batch=2), False),
    (_sized("late", 16, 0.0625), True),  # 512 x 512 pillars: the feature maps dominate
])
def test_the_memory_estimate_bounds_a_real_training_step(world, data, tight):
    """Peak growth of a real process's anonymous memory (sampled every 0.5 ms) over two training steps (model,
    optimizer, batches), against the estimate: never above it, and within 2 x where the feature maps dominate."""
    config = parse_config(data)
    done = subprocess.run([sys.executable, "-c", MEASURE, json.dumps(data), str(world["dataset"])], capture_output=True,
                          text=True, cwd=ROOT, timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    grown = int(done.stdout.split()[-1])
    import simgen.datasets
    from train.preflight import dataset_points_per_frame

    estimate = estimate_memory(
        config, dataset_points_per_frame(simgen.datasets.open(world["dataset"])), True, host=False
    )
    needed = estimate.total(config.train.batch_size) - estimate.nms  # no learning curve: no NMS
    print(f"grown {grown / 2**20:.0f} MiB, estimate {needed / 2**20:.0f} MiB")
    assert grown <= needed
    if tight:
        assert needed <= 2 * grown


def test_check_memory_names_the_field_and_the_limit():
    """Against a given memory size: the model's weights, one sample (its maps, or its points), the NMS, the batch;
    the limit in the line."""
    cpu = torch.device("cpu")
    config = load_config(ROOT / "train" / "configs" / "paper" / "late.yaml")
    estimate = estimate_memory(config, 30_000, training=True, host=True)
    need = estimate.total(config.train.batch_size)
    check_memory(config, 30_000, cpu, training=True, memory=math.ceil(need / 0.8) + 1)  # fits
    with pytest.raises(UserError, match=r"^'train.batch_size': 8 samples need .* at most [1-7] a batch here$"):
        check_memory(config, 30_000, cpu, training=True, memory=int(need / 0.8) - estimate.per_sample)
    with pytest.raises(UserError, match=r"^'data.pillar_size_m': 1 sample of the 320 x 320 pillar grid"):
        check_memory(config, 30_000, cpu, training=True, memory=int((estimate.fixed + estimate.per_sample) / 0.8) - 1)
    with pytest.raises(UserError, match=r"^'model.backbone_2d.channels': 6,160,304 parameters and 204,800 anchors"):
        check_memory(config, 30_000, cpu, training=True, memory=int(estimate.fixed / 0.8) - 1)
    curve = config.model_copy(update={"train": config.train.model_copy(update={"batch_size": 1, "eval_every": 10})})
    with_nms = estimate_memory(curve, 30_000, training=True, host=True)
    with pytest.raises(UserError, match=r"^'infer.pre_nms': NMS of 500 boxes may need .* at most \d+ boxes here$"):
        check_memory(curve, 30_000, cpu, training=True, memory=int((with_nms.total(1) - with_nms.nms // 2) / 0.8))
    crowded = estimate_memory(config, 3_000_000, training=True, host=True)  # points dominate a sample
    with pytest.raises(
        UserError, match=r"^'model.pillar_encoder.channels': 1 sample of up to 3,000,000 points a frame"
    ):
        check_memory(config, 3_000_000, cpu, training=True, memory=int((crowded.fixed + crowded.per_sample) / 0.8) - 1)
    inference = estimate_memory(config, 30_000, training=False, host=True)
    assert inference.total(2) < estimate.total(2) and inference.nms == 500**2 * NMS_BYTES_PER_PAIR
    with pytest.raises(UserError, match=r"^'data.pillar_size_m': 2 samples of the 320 x 320 .* for inference"):
        check_memory(
            config,
            30_000,
            cpu,
            training=False,
            batch=2,
            memory=int((inference.fixed + 2 * inference.per_sample) / 0.8) - 1,
        )


def test_workers_are_held_to_the_cores():
    cores = cpu_cores()
    config = parse_config(_tiny("late"))
    check_workers(config.model_copy(update={"train": config.train.model_copy(update={"workers": cores})}))
    with pytest.raises(
        UserError, match=rf"^'train.workers': {cores + 1} loader processes, this machine has {cores} CPU cores"
    ):
        check_workers(config.model_copy(update={"train": config.train.model_copy(update={"workers": cores + 1})}))


def _trained(tmp_path: Path, data: dict, iteration: int, optimizer: bool = True) -> Path:
    config = parse_config(data)
    model = Detector(config)
    adam = torch.optim.AdamW(model.parameters())
    path = tmp_path / f"checkpoint_{iteration}.pt"
    save_checkpoint(path, Checkpoint(config, model.state_dict(), adam.state_dict() if optimizer else None, iteration))
    return path


def test_resume_takes_only_a_checkpoint_of_the_same_training(tmp_path):
    data = _tiny("late") | {"train": {**_tiny("late")["train"], "iterations": 10}}
    config = parse_config(data)
    path = _trained(tmp_path, data, 4)
    assert check_resume(path, config).iteration == 4
    other = copy.deepcopy(data)
    other["train"]["workers"], other["infer"]["score_threshold"] = 1, 0.3  # neither changes the weights
    assert check_resume(path, parse_config(other)).iteration == 4
    for field, value in ((("train", "lr"), 0.01), (("train", "iterations"), 20), (("seed",), 5),
                         (("model", "pillar_encoder", "channels"), 16), (("data", "pillar_size_m"), 0.5)):
        changed = copy.deepcopy(data)
        _set(changed, field, value)
        with pytest.raises(UserError, match=rf"trained with '{'.'.join(field)}' .*, this config has {value!r}"):
            check_resume(path, parse_config(changed))
    with pytest.raises(UserError, match="no optimizer state"):
        check_resume(_trained(tmp_path, data, 5, optimizer=False), config)
    for iteration in (0, 10):
        with pytest.raises(UserError, match="nothing to resume"):
            check_resume(_trained(tmp_path, data, iteration), config)
    (tmp_path / "foreign.pt").write_bytes(b"\x80\x02not a checkpoint")
    torch.save({"weights": torch.zeros(3)}, tmp_path / "other.pt")
    for name in ("foreign.pt", "other.pt", "absent.pt"):
        with pytest.raises(UserError) as error:
            check_resume(tmp_path / name, config)
        assert "\n" not in str(error.value)


def _listed(valid: bool):
    return lambda seeds: (valid, ",".join(map(str, seeds)))


@settings(max_examples=200, **SETTINGS)
@given(st.one_of(
    st.lists(st.integers(0, MAX_SEED), min_size=1, max_size=MAX_SEEDS, unique=True).map(_listed(True)),
    st.lists(st.integers(0, MAX_SEED), min_size=MAX_SEEDS + 1, max_size=MAX_SEEDS + 5, unique=True).map(_listed(False)),
    st.lists(st.integers(0, 50), min_size=2, max_size=6).filter(lambda s: len(set(s)) < len(s)).map(_listed(False)),
    st.one_of(st.integers(max_value=-1), st.integers(min_value=MAX_SEED + 1)).map(lambda v: (False, f"1,{v}")),
    st.sampled_from(["", ",", "1,,2", "a", "1.5", "1e3", "٣", "0x1", "+1", " ", "9" * 5000]).map(lambda t: (False, t)),
))
def test_seed_lists_are_parsed_or_refused_in_one_line(case):
    valid, text = case
    if valid:
        assert parse_seeds(text) == tuple(int(s) for s in text.split(","))
        return
    with pytest.raises(UserError) as error:
        parse_seeds(text)
    assert str(error.value).startswith("--seeds: ") and "\n" not in str(error.value) and len(str(error.value)) < 200
