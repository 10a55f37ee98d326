"""train.data and the head's target assigner: track matching, one augmentation for all frames, crop, pillars,
targets."""

import math

import numpy as np
import pytest
import torch

import simgen.datasets
from tests.support.detector import smoke_dataset, tiny_config
from train.data import Sample, augment, crop, load_sample, model_points, pillar_cells
from train.detector.box_coder import apply_direction, decode, direction_bin, encode
from train.detector.model import build_detector


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return simgen.datasets.open(smoke_dataset(tmp_path_factory.getbasetemp(), 6))


@pytest.mark.engine  # `simgen generate` makes the dataset
def test_tracklet_boxes_are_matched_by_track_id(dataset):
    clip = dataset.clips[0]
    sample = load_sample(dataset, clip, 4, tiny_config("late"))
    assert sample.boxes.shape == (len(sample.track_id), 3, 7) and sample.box_mask.all()
    assert len(sample.points) == 3
    for k, index in enumerate((2, 3, 4)):
        frame = dataset.frame(clip, index)
        by_id = dict(zip(frame.track_id.tolist(), frame.boxes))
        for track, box in zip(sample.track_id, sample.boxes[:, k]):
            np.testing.assert_array_equal(box, by_id[int(track)])
    single = load_sample(dataset, clip, 4, tiny_config("single"))
    assert len(single.points) == 1
    np.testing.assert_array_equal(single.points[0][:, :3], dataset.frame(clip, 4).points_m)


def test_boxes_before_a_placement_are_masked(tmp_path):
    """Track 1 placed by the engine at frame 3: the samples at t = 3 and 4 mask its boxes before frame 3
    (another segment of its motion), and the sample at t = 3 says it was placed."""
    from dataclasses import replace

    from tests.support.datasets import make_clip, write_dataset

    frames = make_clip("clip_0000", 6, humanoids=4)
    frames = [
        replace(f, labels=replace(f.labels, discontinuity=np.array([f.index == 3, False, False, False])))
        for f in frames
    ]
    write_dataset(tmp_path, "parquet", [frames])
    data = simgen.datasets.open(tmp_path)
    config = tiny_config("late")
    for t, placed_mask in (
        (2, [True, True, True]),
        (3, [False, False, True]),
        (4, [False, True, True]),
        (5, [True, True, True]),
    ):
        sample = load_sample(data, "clip_0000", t, config)
        one = list(sample.track_id).index(1)
        assert sample.box_mask[one].tolist() == placed_mask, t
        assert sample.placed.tolist() == [t == 3 and track == 1 for track in sample.track_id], t
        assert sample.box_mask[np.flatnonzero(sample.track_id != 1)].all()


def _sample() -> Sample:
    rng = np.random.default_rng(1)
    boxes = np.zeros((2, 3, 7), np.float32)
    boxes[:, :, :3] = rng.uniform(-5, 5, (2, 3, 3))
    boxes[:, :, 3:6] = [0.8, 0.6, 1.8]
    boxes[:, :, 6] = rng.uniform(-3, 3, (2, 3))
    points = []
    for k in range(3):  # points inside each object's box at that frame, in box-local coordinates
        local = rng.uniform(-0.4, 0.4, (2, 20, 3)) * [0.8 / 0.8, 0.6 / 0.8, 1.8 / 0.8]
        yaw = boxes[:, k, 6][:, None]
        xy = np.stack([np.cos(yaw) * local[..., 0] - np.sin(yaw) * local[..., 1],
                       np.sin(yaw) * local[..., 0] + np.cos(yaw) * local[..., 1]], -1)
        xyz = np.concatenate([xy, local[..., 2:]], -1) + boxes[:, k, None, :3]
        points.append(np.column_stack([xyz.reshape(-1, 3), np.full(40, 0.5)]).astype(np.float32))
    return Sample("c", 2, tuple(points), boxes, np.ones((2, 3), bool), np.arange(2), np.zeros(2, bool))


def _local(points: np.ndarray, box: np.ndarray) -> np.ndarray:
    d = points[:, :2] - box[:2]
    c, s = math.cos(box[6]), math.sin(box[6])
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], points[:, 2] - box[2]])


@pytest.mark.parametrize("seed", range(4))
def test_augmentation_moves_every_frame_and_box_together(seed):
    from train.config import AugmentConfig

    before = _sample()
    after = augment(before, AugmentConfig(rotation_rad=3.0, flip_x=True, scale=(0.9, 1.1)), np.random.default_rng(seed))
    scale = after.boxes[0, 0, 3] / before.boxes[0, 0, 3]
    for k in range(3):
        for g in range(2):
            rows = slice(20 * g, 20 * g + 20)
            old, new = (
                _local(before.points[k][rows], before.boxes[g, k]),
                _local(after.points[k][rows], after.boxes[g, k]),
            )
            # A point's place in its box is kept up to the scale, and up to the mirror across the box's axis.
            np.testing.assert_allclose(np.abs(new), np.abs(old) * scale, atol=1e-4)
    np.testing.assert_array_equal(after.points[0][:, 3], before.points[0][:, 3])


def test_crop_keeps_points_and_objects_in_range():
    sample = _sample()
    cropped = crop(sample, (-1.0, -1.0, -0.1, 10.0, 10.0, 2.5))
    for p in cropped.points:
        assert ((p[:, :2] >= -1) & (p[:, :2] < 10)).all() and ((p[:, 2] >= -0.1) & (p[:, 2] < 2.5)).all()
    inside = ((sample.boxes[:, -1, :2] >= -1) & (sample.boxes[:, -1, :2] < 10)).all(1)
    np.testing.assert_array_equal(cropped.track_id, sample.track_id[inside])


def test_pillar_cells_and_early_time_channel():
    config = tiny_config("early")  # x from -16, y from -24, 0.25 m pillars, 128 columns
    xyz = np.array([[-16.0, -24.0, 0.0], [-15.76, -24.0, 0.0], [-16.0, -23.74, 1.0], [15.99, 7.99, 0.0]], np.float32)
    assert pillar_cells(xyz, config).tolist() == [0, 0, 128 + 0, 127 * 128 + 127]
    features, canvas = model_points(_sample(), config)
    assert features.shape == (120, 5) and (canvas == 0).all()
    np.testing.assert_array_equal(np.unique(features[:, 4]), [-2.0, -1.0, 0.0])
    _, late_canvas = model_points(_sample(), tiny_config("late"))
    np.testing.assert_array_equal(np.bincount(late_canvas), [40, 40, 40])


def test_box_coder_round_trip_and_direction():
    rng = np.random.default_rng(2)
    anchors = np.column_stack(
        [rng.uniform(-5, 5, (6, 3)), np.full((6, 3), [0.8, 0.8, 1.7]), rng.choice([0, np.pi / 2], 6)]
    ).astype(np.float32)
    boxes = (
        np.column_stack([rng.uniform(-5, 5, (18, 3)), rng.uniform(0.4, 1.2, (18, 3)), rng.uniform(-3, 3, 18)])
        .reshape(6, 3, 7)
        .astype(np.float32)
    )
    back = decode(torch.from_numpy(anchors), torch.from_numpy(encode(anchors, boxes))).numpy()
    np.testing.assert_allclose(back, boxes, atol=1e-5)
    offset = 0.78539
    bins = direction_bin(boxes[:, -1, 6], offset)
    ambiguous = torch.from_numpy(boxes[:, -1, 6] + np.pi * rng.integers(-2, 3, 6))  # the regression knows yaw mod pi
    fixed = apply_direction(ambiguous, torch.from_numpy(bins), offset).numpy()
    np.testing.assert_allclose(np.cos(fixed), np.cos(boxes[:, -1, 6]), atol=1e-5)
    np.testing.assert_allclose(np.sin(fixed), np.sin(boxes[:, -1, 6]), atol=1e-5)


def test_anchor_targets():
    config = tiny_config("late")
    assigner = build_detector(config).head.assigner
    grid = assigner.grid
    assert len(grid) == 64 * 64 * 2 and grid.cell_m == 0.5
    anchor = grid.anchors[1000]
    tracklet = np.stack([anchor + [-0.2, 0, 0, 0, 0, 0, 0], anchor + [-0.1, 0, 0, 0, 0, 0, 0], anchor])[None]
    nearby = np.stack([tracklet[0, :, :] + [3, 3, 0, 0, 0, 0, 0]])  # a second object, 4 m away
    targets = assigner(np.concatenate([tracklet, nearby]).astype(np.float32), np.ones((2, 3), bool))
    assert targets.labels[1000] == 1 and 1000 in targets.positives
    assert set(np.unique(targets.labels)) <= {-1, 0, 1} and (targets.labels == 1).sum() == len(targets.positives)
    row = targets.positives.tolist().index(1000)
    back = decode(torch.from_numpy(grid.anchors[targets.positives]), torch.from_numpy(targets.deltas)).numpy()
    np.testing.assert_allclose(back[row], tracklet[0], atol=1e-5)
    # Far from both objects every anchor is a negative.
    far = np.linalg.norm(grid.anchors[:, :2] - anchor[:2], axis=1) > 8
    assert (targets.labels[far] == 0).all()


def test_the_data_layer_does_not_import_the_models():
    """train.data hands samples to the head's target assigner; it never imports train.detector (no import cycle)."""
    import subprocess
    import sys

    from tests.support import ROOT

    code = "import sys, train.data; print(sorted(m for m in sys.modules if m.startswith('train.detector')))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert done.stdout.strip() == "[]"


@pytest.mark.parametrize("protocol", ["clip", "frame"])
def test_no_training_window_shares_a_frame_with_a_val_window(tmp_path, protocol):
    """Both splits: train and val windows (t-2..t) never share a frame; `frame` holds out about one clip's
    frames spread over every clip, `clip` whole clips."""
    from tests.support.datasets import make_clip, write_dataset
    from train.data import sample_keys

    write_dataset(
        tmp_path, "parquet", [make_clip(f"clip_{i:04d}", 40, points=50, humanoids=2, seed=i) for i in range(4)]
    )
    data = simgen.datasets.open(tmp_path)
    train, val = sample_keys(data, "train", protocol), sample_keys(data, "val", protocol)

    def frames(keys):
        return {(clip, t - k) for clip, t in keys for k in range(3)}

    assert train and val and not frames(train) & frames(val)
    assert set(train) | set(val) <= set(sample_keys(data, None, protocol))
    if protocol == "frame":
        assert {clip for clip, _ in val} == set(data.clips)
        assert abs(len(frames(val)) - 40) <= 6  # about one clip's frames (whole windows of three)
        nearest = min(abs(t - v) for c, t in train for d, v in val if c == d)
        assert nearest == 3  # one frame (~0.1 s) between a training window and a val window
    else:
        assert {clip for clip, _ in val} == {c for c in data.clips if data.split(c) == "val"}
