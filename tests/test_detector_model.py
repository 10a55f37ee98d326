"""The three detectors' shapes, late fusion, the loss, NMS, configs and checkpoints."""

import numpy as np
import pytest
import torch
import yaml
from detector_support import tiny_config

from simgen.errors import UserError
from train.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from train.config import load_config, parse_config
from train.data import Encoded, Sample, collate, encode_sample
from train.losses import detection_loss
from train.models.anchors import AnchorGrid
from train.models.detector import build_detector
from train.models.fusion import LateFusion
from train.nms import nms_bev
from train.postprocess import postprocess


def _batch(config, samples=2):
    rng = np.random.default_rng(0)
    grid = AnchorGrid(config)
    items: list[Encoded] = []
    for _ in range(samples):
        points = tuple(
            np.column_stack([rng.uniform([-16, -24, 0], [16, 8, 2], (500, 3)), rng.uniform(0, 1, 500)]).astype(np.float32)
            for _ in range(config.model.input_frames)
        )
        boxes = np.tile(np.array([1.0, -5.0, 0.9, 0.8, 0.6, 1.8, 0.3], np.float32), (1, 3, 1))
        items.append(encode_sample(Sample("c", 2, points, boxes, np.ones((1, 3), bool), np.arange(1)), config, grid))
    rows, cols = config.data.grid_size
    return collate(items, config.model.canvases, rows * cols, len(grid)), grid


@pytest.mark.parametrize("fusion, boxes", [("single", 1), ("early", 1), ("late", 3)])
def test_forward_loss_and_detections(fusion, boxes):
    config = tiny_config(fusion)
    batch, grid = _batch(config)
    model = build_detector(config)
    out = model(batch)
    assert out.scores.shape == (2, len(grid)) and out.deltas.shape == (2, len(grid), boxes, 7)
    assert out.direction.shape == (2, len(grid), 2)
    terms = detection_loss(out, batch, config.loss)
    assert torch.isfinite(terms.total) and len(terms.loc) == boxes
    terms.total.backward()
    assert all(p.grad is not None for p in model.parameters() if p.requires_grad)
    model.eval()
    with torch.no_grad():
        found = postprocess(model(batch), torch.from_numpy(grid.anchors), config)
    assert len(found) == 2 and found[0].boxes.shape[1:] == (boxes, 7)


def test_late_fusion_convolves_three_frames_into_one_without_temporal_padding():
    fusion = LateFusion((4, 6), frames=3)
    levels = [torch.randn(2 * 3, 4, 5, 5), torch.randn(2 * 3, 6, 5, 5)]
    assert fusion(levels, batch_size=2).shape == (2, 10, 5, 5)
    assert fusion.levels[0][0].kernel_size == (3, 3, 3) and fusion.levels[0][0].padding == (0, 1, 1)
    # Frame order matters: swapping t-2 and t changes the output (the kernel is not symmetric in time).
    swapped = [x.view(2, 3, *x.shape[1:]).flip(1).reshape(x.shape) for x in levels]
    fusion.eval()
    assert not torch.allclose(fusion(levels, 2), fusion(swapped, 2))


def test_nms_keeps_the_best_of_overlapping_boxes():
    boxes = np.array([[0, 0, 1, 0.8, 0.6, 1.8, 0], [0.1, 0, 1, 0.8, 0.6, 1.8, 0], [3, 0, 1, 0.8, 0.6, 1.8, 0]], np.float32)
    scores = np.array([0.5, 0.9, 0.7], np.float32)
    assert nms_bev(boxes, scores, 0.2, 10).tolist() == [1, 2]
    assert nms_bev(boxes, scores, 0.2, 1).tolist() == [1]
    assert nms_bev(boxes[:0], scores[:0], 0.2, 10).tolist() == []


def test_configs_load_and_reject_bad_keys(tmp_path):
    for name, fusion in (("single", "single"), ("early", "early"), ("late", "late")):
        assert load_config(f"train/configs/{name}.yaml").model.fusion == fusion
    raw = yaml.safe_load(open("train/configs/late.yaml"))
    raw["model"]["backbone"]["colour"] = 3
    with pytest.raises(UserError, match=r"unknown key 'model.backbone.colour'"):
        parse_config(raw)
    raw = yaml.safe_load(open("train/configs/single.yaml"))
    raw["model"]["tracklet_boxes"] = 3
    with pytest.raises(UserError, match="single-frame model regresses 1 box"):
        parse_config(raw)
    raw["model"]["tracklet_boxes"], raw["data"]["pillar_size_m"] = 1, 0.3
    with pytest.raises(UserError, match="whole multiples"):
        parse_config(raw)
    with pytest.raises(UserError, match="no such config file"):
        load_config(tmp_path / "missing.yaml")


def test_checkpoint_round_trip_and_foreign_files(tmp_path):
    config = tiny_config("late")
    model = build_detector(config)
    path = tmp_path / "checkpoint.pt"
    save_checkpoint(path, Checkpoint(config, model.state_dict(), None, 7))
    loaded = load_checkpoint(path)
    assert loaded.config == config and loaded.iteration == 7
    assert all(torch.equal(loaded.model[k], v) for k, v in model.state_dict().items())
    assert [p.name for p in tmp_path.iterdir()] == ["checkpoint.pt"]  # no temporary left behind
    (tmp_path / "text.pt").write_text("hello")
    torch.save({"weights": torch.zeros(2)}, tmp_path / "other.pt")
    for name in ("text.pt", "other.pt", "missing.pt"):
        with pytest.raises(UserError) as error:
            load_checkpoint(tmp_path / name)
        assert "\n" not in str(error.value)
