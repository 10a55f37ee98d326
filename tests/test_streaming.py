"""The val pass's streamed inference (train.detector.streaming) against the model's own forward, window by window."""

import numpy as np
import pytest
import torch

from tests.support.detector import tiny_config
from train.data import Sample, collate, encode_sample
from train.detector.folding import fold_batchnorm
from train.detector.model import build_detector
from train.detector.postprocess import postprocess
from train.detector.streaming import fused_features, stream


def _windows(config, clips=("a", "b"), frames=4):
    """Encoded windows t = 2 .. frames - 1 of two clips of random frames (each frame the same points in every
    window)."""
    rng = np.random.default_rng(3)
    out = []
    for clip in clips:
        clouds = [
            np.column_stack([rng.uniform([-16, -24, 0], [16, 8, 2], (2000, 3)), rng.uniform(0, 1, 2000)]).astype(
                np.float32
            )
            for _ in range(frames)
        ]
        for t in range(2, frames):
            boxes = np.tile(np.array([1.0, -5.0, 0.9, 0.8, 0.6, 1.8, 0.3], np.float32), (1, 3, 1))
            points = tuple(clouds[t - config.model.fusion.input_frames + 1: t + 1])
            sample = Sample(clip, t, points, boxes, np.ones((1, 3), bool), np.arange(1), np.zeros(1, bool))
            out.append(encode_sample(sample, config))
    return out


def _model(fusion):
    """A tiny detector with BatchNorm statistics and affine parts far from identity (to test folding), the best
    150 anchors of any score to NMS."""
    config = tiny_config(fusion)
    infer = config.infer.model_copy(update={"score_threshold": 0.0, "pre_nms": 150, "max_detections": 100})
    config = config.model_copy(update={"infer": infer})
    model = build_detector(config)
    generator = torch.Generator().manual_seed(1)
    for module in model.modules():
        if isinstance(module, torch.nn.modules.batchnorm._BatchNorm):
            for tensor in (module.running_mean, module.weight, module.bias):
                tensor.data = torch.randn(tensor.shape, generator=generator) * 0.5
            module.running_var.data = torch.rand(module.running_var.shape, generator=generator) + 0.5
    return config, model.eval()


@pytest.mark.parametrize("fusion", ["single", "early", "late"])
def test_streamed_head_outputs_equal_the_forward_of_each_window(fusion):
    """Every anchor's score, deltas and direction logits from the streamed features (each frame's backbone
    once, BatchNorm folded, box convolutions per anchor) equal the model's forward on the window alone."""
    config, model = _model(fusion)
    windows = _windows(config)
    rows, cols = config.data.grid_size
    folded = fold_batchnorm(model)
    anchors = torch.arange(len(model.head.anchors))
    with torch.inference_mode():
        streamed = list(fused_features(folded, config, windows, torch.device("cpu")))
        assert [(s.clip, s.index) for s, _ in streamed] == [(w.sample.clip, w.sample.index) for w in windows]
        for encoded, (_, features) in zip(windows, streamed):
            alone = model(collate([encoded], config.model.fusion.canvases, rows * cols))
            deltas, direction = folded.head.anchor_boxes(features[0], anchors)
            torch.testing.assert_close(folded.head.anchor_scores(features), alone.scores, rtol=1e-4, atol=1e-4)
            torch.testing.assert_close(deltas, alone.deltas[0], rtol=1e-4, atol=1e-4)
            torch.testing.assert_close(direction, alone.direction[0], rtol=1e-4, atol=1e-4)


def test_streamed_detections_equal_the_forward_of_each_window():
    """The streamed tracklets of each late-fusion window (scored, decoded, NMS) equal postprocess of the
    forward on it alone."""
    config, model = _model("late")
    windows = _windows(config)
    rows, cols = config.data.grid_size
    streamed = list(stream(model, config, windows, torch.device("cpu")))
    for encoded, (_, found) in zip(windows, streamed):
        with torch.no_grad():
            (alone,) = postprocess(
                model(collate([encoded], config.model.fusion.canvases, rows * cols)), model.head.anchors, config
            )
        assert len(alone.scores) > 10 and found.boxes.shape == alone.boxes.shape
        np.testing.assert_allclose(found.scores, alone.scores, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(found.boxes, alone.boxes, rtol=1e-5, atol=1e-4)
