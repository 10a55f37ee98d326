"""Inference over a split's windows in clip order, each frame's pillars and backbone run once.

A late-fusion window at t reads frames t-2, t-1 and t, each on its own canvas, and the pillar
encoder and backbone see one canvas alone: so consecutive windows of a clip share two frames'
backbone levels, kept here, and only the new frame is computed (a third of the work). Without
augmentation a frame's points are the same in every window that holds it, so this is the
model's own forward, in another order. The BatchNorms are folded (train.detector.folding), and the
head's box and direction convolutions run only at the anchors that pass the score threshold.
Single-frame models reuse nothing (each frame is one window); early fusion merges the sweeps on
one canvas, so each window is its own key.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import replace

import numpy as np
import torch

from train.config import DetectorConfig
from train.data import Batch, Encoded, Sample, collate
from train.detector.folding import fold_batchnorm
from train.detector.model import Detector
from train.detector.postprocess import Detections, candidates, tracklets


def canvas_keys(sample: Sample, config: DetectorConfig) -> list[tuple[str, int, int]]:
    """What each input canvas of `sample` holds, oldest first: (clip, frame, 0) where a canvas is one
    frame (late fusion, single frame), else (clip, window t, 1): the same key, the same canvas."""
    canvases = config.model.fusion.canvases
    if canvases != config.model.fusion.input_frames:
        return [(sample.clip, sample.index, 1)]
    return [(sample.clip, sample.index - canvases + 1 + k, 0) for k in range(canvases)]


def _canvases(encoded: Encoded, wanted: list[int], grid_cells: int) -> Batch:
    """A batch of the `wanted` canvases of one encoded sample, one canvas per item."""
    items = [
        replace(
            encoded,
            features=encoded.features[encoded.canvas == k],
            cells=encoded.cells[encoded.canvas == k],
            canvas=np.zeros(int(np.count_nonzero(encoded.canvas == k)), np.int64),
            targets=None,
        )
        for k in wanted
    ]
    return collate(items, 1, grid_cells)


class WindowFeatures:
    """The head's input of one window after another (in clip order), each canvas's backbone levels and fusion
    terms computed once, one canvas at a time, and kept while a window holds it: `pillars` (the new canvases'
    pillar batches, CPU) then `fuse` (the network up to the head), two calls so that a caller can time them
    apart. `keep` computes a frame's canvas before any window holds it (a sensor's first frames)."""

    def __init__(self, folded: Detector, config: DetectorConfig, device: torch.device) -> None:
        self.folded, self.config, self.device = folded, config, device
        self.kept: dict[tuple[str, int, int], list[torch.Tensor]] = {}

    def pillars(self, encoded: Encoded) -> tuple[list[tuple[str, int, int]], list[tuple[int, Batch]]]:
        """The window's canvas keys, and each new canvas's position in them with its pillar batch."""
        rows, cols = self.config.data.grid_size
        keys = canvas_keys(encoded.sample, self.config)
        return keys, [(k, _canvases(encoded, [k], rows * cols)) for k, key in enumerate(keys) if key not in self.kept]

    def _terms(self, batch: Batch) -> list[torch.Tensor]:
        levels = self.folded.canvas_levels(batch.to(self.device), 1)
        return [term[0] for term in self.folded.fusion.frame_terms(levels)]

    def fuse(self, keys: list[tuple[str, int, int]], batches: list[tuple[int, Batch]]) -> torch.Tensor:
        """The head's input (1, C, H, W) of the window `pillars` prepared."""
        self.kept.update({keys[k]: self._terms(batch) for k, batch in batches})
        self.kept = {key: self.kept[key] for key in keys}
        return self.folded.fusion.fuse_frame_terms([self.kept[key] for key in keys])

    def keep(self, encoded: Encoded) -> None:
        """Compute and keep the canvas of a lone frame (`encoded`: a sample of that frame alone, canvas 0) that
        later windows will hold, where a canvas is one frame (late fusion, single frame)."""
        rows, cols = self.config.data.grid_size
        fusion = self.config.model.fusion
        if fusion.canvases == fusion.input_frames > 1:
            key = (encoded.sample.clip, encoded.sample.index, 0)
            self.kept[key] = self._terms(_canvases(encoded, [0], rows * cols))


def fused_features(folded: Detector, config: DetectorConfig, samples: Iterable[Encoded], device: torch.device
                   ) -> Iterator[tuple[Sample, torch.Tensor]]:
    """Each encoded sample (a SampleSet without augmentation, in order) with the head's input (1, C, H, W)."""
    windows = WindowFeatures(folded, config, device)
    for encoded in samples:
        yield encoded.sample, windows.fuse(*windows.pillars(encoded))


def head(folded: Detector, config: DetectorConfig, features: torch.Tensor
         ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """The head on one window's input (1, C, H, W), its box convolutions only at the anchors above the score
    threshold: (those anchors (K,), every anchor's score (N_a,), their deltas and direction logits)."""
    keep, scores = candidates(folded.head.anchor_scores(features)[0], config)
    return keep, scores, *folded.head.anchor_boxes(features[0], keep)


def stream(model: Detector, config: DetectorConfig, samples: Sequence[Encoded], device: torch.device
           ) -> Iterator[tuple[Sample, Detections]]:
    """Each encoded sample (a SampleSet without augmentation, in order) with its tracklets, as `model(batch)`
    and train.detector.postprocess would give them (to float32 rounding)."""
    folded = fold_batchnorm(model).to(device)
    with torch.inference_mode():
        for sample, features in fused_features(folded, config, samples, device):
            yield sample, tracklets(*head(folded, config, features), folded.head.anchors, config)
