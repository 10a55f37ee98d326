"""KITTI's AP (train.evaluation.detection): perfect detections, hand cases worked by KITTI's official rule, matching.

The rotated IoU underneath is tested against shapely in test_geometry.py.
"""

import math

import numpy as np
import pytest

from train.evaluation.detection import FrameBoxes, average_precision, detection_ap, match_frame


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
    for _ in range(80):  # 480 boxes: KITTI's rule reads 100 only with enough of them
        truth = boxes(rng, 6)
        frames.append(FrameBoxes(truth.copy(), rng.uniform(0.2, 1.0, 6).astype(np.float32), truth))
    assert detection_ap(frames, iou, 0.5, points) == pytest.approx(100.0)


def test_hand_computed_case():
    """40 frames of two objects; per frame a hit scored 0.9 - f/1000, a miss 0.6 - f/1000, a hit 0.3 - f/1000.

    Ranked: 40 hits, 40 misses, 40 hits; 80 boxes. Thresholds at recall k/40 are the scores of hit
    2k (hit 1 for k = 0): precision 1 up to k = 20, then 2k / (2k + 40), whose best at or below
    the threshold is 80/120 = 2/3. R40: 20 levels at 1 and 20 at 2/3 -> 83.33.
    R11 (every fourth level): 0..0.5 (6 levels) at 1, 0.6..1 at 2/3 -> 84.85.
    """
    truth = np.array([[0, 0, 0.9, 0.8, 0.6, 1.8, 0.0], [10, 0, 0.9, 0.8, 0.6, 1.8, 1.0]], np.float32)
    shifted = truth[0] + np.array([0.05, 0, 0, 0, 0, 0, 0], np.float32)  # IoU 0.88 with the first object
    far = truth[0] + np.array([5, 5, 0, 0, 0, 0, 0], np.float32)
    frames = [
        FrameBoxes(np.stack([shifted, far, truth[1]]), np.array([0.9, 0.6, 0.3], np.float32) - f / 1000, truth)
        for f in range(40)
    ]
    assert detection_ap(frames, "bev", 0.5, 40) == pytest.approx(100 * (20 + 20 * 2 / 3) / 40)
    assert detection_ap(frames, "3d", 0.5, 11) == pytest.approx(100 * (6 + 5 * 2 / 3) / 11)


def test_maximum_recall_between_two_levels_credits_the_nearest_level():
    """80 boxes, 41 hits at precision 1: recall 0.5125, between levels 20/40 and 21/40.

    KITTI's thresholds: level 0 at hit 1, level k at hit 2k (recall k/40), and the last hit's
    score always, for level 21: 21 levels of 1 out of 40 -> 52.5 (a rule that needs recall >= the
    level reads 50). R11: levels 0, 4, ..., 20 of the 41 -> 6/11.
    """
    scores, hits = np.linspace(1.0, 0.2, 41).astype(np.float32), np.ones(41, bool)
    assert average_precision(scores, hits, 80, 40) == pytest.approx(100 * 21 / 40)
    assert average_precision(scores, hits, 80, 11) == pytest.approx(100 * 6 / 11)
    # One level further: 42 hits reach recall 0.525 = 21/40 exactly; the last hit is level 21 again.
    assert average_precision(np.linspace(1.0, 0.2, 42), np.ones(42, bool), 80, 40) == pytest.approx(100 * 21 / 40)


def test_a_perfect_detector_of_40_boxes_reads_97_5():
    """Each hit takes a level, level 0 the first: the 40th hit is level 39, level 40 is never reached."""
    assert average_precision(np.linspace(1.0, 0.1, 40), np.ones(40, bool), 40, 40) == pytest.approx(97.5)


def test_precision_is_of_every_detection_scoring_at_least_the_threshold():
    """80 boxes: 40 hits, then a miss and a hit tied at one score, then 39 hits.

    The miss counts at every threshold from the tied score down: levels 1..20 (hits 2..40) read 1,
    levels 21..40 (hits 42..80) j / (j + 1), at best 80/81 at the last hit.
    """
    scores = np.concatenate([np.linspace(1.0, 0.6, 40), [0.5, 0.5], np.linspace(0.4, 0.1, 39)])
    hits = np.ones(81, bool)
    hits[40] = False
    assert average_precision(scores, hits, 80, 40) == pytest.approx(100 * (20 + 20 * 80 / 81) / 40)


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


def test_centre_distance_matches_within_metres_on_the_pitch_plane():
    truth = np.array([[0, 0, 0.9, 0.8, 0.6, 1.8, 0.0]], np.float32)
    near = truth + np.array([0.5, 0, 1.0, 0.5, 0, 0, 1.0], np.float32)  # 0.5 m on the pitch, other height and size
    frame = FrameBoxes(near, np.ones(1, np.float32), truth)
    assert match_frame(frame, "centre", 0.5).tolist() == [True]  # at the threshold: a match
    assert match_frame(frame, "centre", 0.25).tolist() == [False]
    assert match_frame(frame, "3d", 0.5).tolist() == [False]


def test_ignored_boxes_count_neither_way():
    """160 boxes, 80 of them ignored (no points): detections on those leave the ranking, the others score as
    if the ignored boxes were not there; the missing visible ones are still misses."""
    truth = boxes(np.random.default_rng(5), 160)
    ignore = np.arange(160) % 2 == 1
    scores = np.linspace(1.0, 0.2, 160).astype(np.float32)
    frame = FrameBoxes(truth.copy(), scores, truth, ignore)
    assert frame.counted_truth == 80
    assert detection_ap([frame], "bev", 0.5, 40) == pytest.approx(100.0)
    half = FrameBoxes(truth[:80].copy(), scores[:80], truth, ignore)  # finds 40 of the 80 visible boxes
    alone = FrameBoxes(truth[:80:2].copy(), scores[:80:2], truth[~ignore])
    assert detection_ap([half], "bev", 0.5, 40) == pytest.approx(detection_ap([alone], "bev", 0.5, 40))
    assert detection_ap([half], "bev", 0.5, 40) == pytest.approx(50.0)  # recall 1/2 exactly: levels 1..20


def test_edge_cases():
    assert average_precision(np.zeros(0, np.float32), np.zeros(0, bool), 5, 40) == 0.0
    assert math.isnan(average_precision(np.ones(2, np.float32), np.zeros(2, bool), 0, 40))
    # One hit of two boxes: its score is the threshold of level 0 only, which R40 does not read.
    assert average_precision(np.array([0.9], np.float32), np.array([True]), 2, 40) == 0.0
    assert average_precision(np.array([0.9], np.float32), np.array([True]), 2, 11) == pytest.approx(100 / 11)
    assert average_precision(np.array([0.9, 0.8], np.float32), np.zeros(2, bool), 2, 40) == 0.0
    with pytest.raises(ValueError):
        average_precision(np.ones(1, np.float32), np.ones(1, bool), 1, 20)


def test_the_decomposition_names_the_error_that_costs_the_most():
    """Ten labelled players 3 m apart; eight found 0.3 m off centre, otherwise exact (3D IoU 0.33: false
    positives), two missed, one of them invisible. Fixing the centre gives the AP of exact detections;
    size, heading and z fix nothing; the misses stay."""
    from train.evaluation.decomposition import decompose

    truth = np.array([[3.0 * i, 0.0, 0.9, 0.6, 0.6, 1.8, 0.1 * i] for i in range(10)], np.float32)
    found = truth[:8].copy()
    found[:, 0] += 0.3
    scores = np.linspace(0.9, 0.5, 8).astype(np.float32)
    exact = detection_ap([FrameBoxes(truth[:8], scores, truth)], "3d")
    d = decompose([FrameBoxes(found, scores, truth)], [np.arange(10) != 9])
    assert d.ap == 0.0 and exact > 10 and d.fixed["centre"] == d.fixed["all"] == pytest.approx(exact)
    assert d.fixed["size"] == d.fixed["heading"] == d.fixed["z"] == 0.0
    assert (d.matched, d.detections, d.missed, d.truth, d.missed_invisible) == (8, 8, 2, 10, 1)
    assert d.costliest == "centre"
