"""KITTI-style AP (train.metrics.detection): perfect detections, a hand-computed case, matching rules.

The rotated IoU underneath is tested against shapely in test_geometry.py.
"""

import math

import numpy as np
import pytest

from train.metrics.detection import FrameBoxes, average_precision, detection_ap, match_frame


def boxes(rng: np.random.Generator, n: int) -> np.ndarray:
    """Player-sized boxes on a 3 m grid (never touching), any yaw."""
    cells = rng.choice(400, n, replace=False)
    centre = np.column_stack([cells % 20 * 3.0, cells // 20 * 3.0, np.full(n, 0.9)])
    size = rng.uniform([0.5, 0.4, 1.6], [1.0, 0.8, 1.9], (n, 3))
    return np.column_stack([centre, size, rng.uniform(-np.pi, np.pi, n)]).astype(np.float32)


@pytest.mark.parametrize("iou", ["bev", "3d"])
@pytest.mark.parametrize("points", [40, 11])
def test_perfect_detections_score_100(iou, points):
    rng = np.random.default_rng(0)
    frames = []
    for _ in range(8):
        truth = boxes(rng, 6)
        frames.append(FrameBoxes(truth.copy(), rng.uniform(0.2, 1.0, 6).astype(np.float32), truth))
    assert detection_ap(frames, iou, 0.5, points) == pytest.approx(100.0)


def test_hand_computed_case():
    """Two objects; detections 0.9 (hit), 0.8 (miss), 0.7 (hit).

    Precision 1, 1/2, 2/3 at recall 1/2, 1/2, 1. Interpolated: 1 up to recall 1/2, then 2/3.
    R40: 20 levels at 1 and 20 at 2/3 -> 83.33. R11: 0..0.5 (6 levels) at 1, 0.6..1 at 2/3 -> 84.85.
    """
    truth = np.array([[0, 0, 0.9, 0.8, 0.6, 1.8, 0.0], [10, 0, 0.9, 0.8, 0.6, 1.8, 1.0]], np.float32)
    shifted = truth[0] + np.array([0.05, 0, 0, 0, 0, 0, 0], np.float32)  # IoU 0.88 with the first object
    far = truth[0] + np.array([5, 5, 0, 0, 0, 0, 0], np.float32)
    frames = [FrameBoxes(np.stack([shifted, far, truth[1]]), np.array([0.9, 0.8, 0.7], np.float32), truth)]
    assert detection_ap(frames, "bev", 0.5, 40) == pytest.approx(100 * (20 + 20 * 2 / 3) / 40)
    assert detection_ap(frames, "3d", 0.5, 11) == pytest.approx(100 * (6 + 5 * 2 / 3) / 11)


def test_matching_is_greedy_by_score_and_one_to_one():
    truth = np.array([[0, 0, 0.9, 0.8, 0.6, 1.8, 0.0]], np.float32)
    twice = FrameBoxes(np.stack([truth[0], truth[0]]), np.array([0.4, 0.6], np.float32), truth)
    assert match_frame(twice, "bev", 0.5).tolist() == [False, True]  # the higher score takes the object


def test_iou_threshold_is_inclusive_and_3d_needs_height():
    truth = np.array([[0, 0, 0.9, 3.0, 1.0, 1.8, 0.0]], np.float32)
    moved = np.array([[1.0, 0, 0.9, 3.0, 1.0, 1.8, 0.0]], np.float32)  # overlap 2, union 4: IoU 1/2 exactly
    assert match_frame(FrameBoxes(moved, np.ones(1, np.float32), truth), "bev", 0.5).tolist() == [True]
    lifted = truth + np.array([0, 0, 1.2, 0, 0, 0, 0], np.float32)  # same footprint, a third of the height shared
    assert match_frame(FrameBoxes(lifted, np.ones(1, np.float32), truth), "bev", 0.5).tolist() == [True]
    assert match_frame(FrameBoxes(lifted, np.ones(1, np.float32), truth), "3d", 0.5).tolist() == [False]


def test_edge_cases():
    assert average_precision(np.zeros(0, np.float32), np.zeros(0, bool), 5, 40) == 0.0
    assert math.isnan(average_precision(np.ones(2, np.float32), np.zeros(2, bool), 0, 40))
    half = average_precision(np.array([0.9], np.float32), np.array([True]), 2, 40)
    assert half == pytest.approx(50.0)  # recall 1/2 at precision 1
    with pytest.raises(ValueError):
        average_precision(np.ones(1, np.float32), np.ones(1, bool), 1, 20)
