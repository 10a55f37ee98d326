"""AP by distance from the sensor (train.evaluation.ap_table.ap_by_distance) and by pitch zone (ap_by_zone),
and KITTI's rule for detections outside a bin (FrameBoxes.ignore_unmatched), on hand-built frames."""

import numpy as np
import pytest

from train.config import TRACKLET_FRAMES
from train.data import Sample
from train.detector.postprocess import Detections
from train.evaluation.ap_table import ap_by_distance, ap_by_zone, average_precisions, mean_ap, sensor_distance_m
from train.evaluation.detection import FrameBoxes, detection_ap

SENSOR = np.array([[0.0, -35.0]])


def player(x: float, y: float, yaw: float = 0.0) -> np.ndarray:
    """(7,) a player-sized box standing at (x, y)."""
    return np.array([x, y, 0.9, 0.8, 0.6, 1.8, yaw], np.float32)


def sample(truth: np.ndarray, index: int = 2) -> Sample:
    """A sample whose objects stand still over t-2..t at `truth` (G, 7)."""
    boxes = np.repeat(np.asarray(truth, np.float32)[:, None], TRACKLET_FRAMES, axis=1)
    g = len(truth)
    return Sample("clip_0000", index, (), boxes, np.ones((g, TRACKLET_FRAMES), bool), np.arange(g, dtype=np.int64),
                  np.zeros(g, bool))


def found(boxes: np.ndarray, scores) -> Detections:
    boxes = np.asarray(boxes, np.float32).reshape(-1, 7)
    return Detections(np.repeat(boxes[:, None], TRACKLET_FRAMES, axis=1), np.asarray(scores, np.float32))


def rows_of(rows, recall_points: int = 40) -> dict[tuple[float, str], object]:
    return {(r.low_m, r.iou): r for r in rows if r.recall_points == recall_points}


def test_distance_is_on_the_pitch_plane_from_the_nearest_sensor():
    boxes = np.stack([player(3.0, -31.0), player(0.0, 40.0)])
    boxes[0, 2] = 2.5  # height does not count
    assert sensor_distance_m(boxes, SENSOR).tolist() == pytest.approx([5.0, 75.0])
    two = np.array([[0.0, -35.0], [0.0, 35.0]])
    assert sensor_distance_m(boxes, two).tolist() == pytest.approx([5.0, 5.0])


def test_bins_hold_their_lower_edge_and_every_box_counts_in_one():
    """Boxes at 5, 10 (the edge: bin 10-20), 19.99 and 25 m from the sensor, found perfectly 60 times over."""
    truth = np.stack([player(0.0, -30.0), player(10.0, -35.0), player(0.0, -15.01), player(0.0, -10.0)])
    results = [(sample(truth), found(truth, [0.9, 0.8, 0.7, 0.6])) for _ in range(60)]
    rows = ap_by_distance(results, SENSOR, 10.0)
    by_bin = rows_of(rows)
    assert sorted({low for low, _ in by_bin}) == [0.0, 10.0, 20.0]
    assert [by_bin[(low, "3d")].truth for low in (0.0, 10.0, 20.0)] == [60, 120, 60]
    assert [by_bin[(low, "3d")].detections for low in (0.0, 10.0, 20.0)] == [60, 120, 60]
    assert all(r.ap == pytest.approx(100.0) for r in rows)
    assert {(r.low_m, r.high_m) for r in rows} == {(0.0, 10.0), (10.0, 20.0), (20.0, 30.0)}


def test_a_detection_across_a_bin_edge_counts_only_for_its_box():
    """A box at 19.95 m found at 20.05 m: a true positive in 10-20 m and nothing in 20-30 m, whose own box is
    found exactly; a detection of nothing at 25 m is a false positive in 20-30 m only."""
    truth = np.stack([player(0.0, -15.05), player(8.0, -10.0)])  # 19.95 m and 26.2 m
    across = player(0.0, -14.95)  # 20.05 m: IoU 0.71 with its box
    results = [(sample(truth), found(np.stack([across, truth[1]]), [0.9, 0.8])) for _ in range(50)]
    by_bin = rows_of(ap_by_distance(results, SENSOR, 10.0))
    assert by_bin[(10.0, "bev")].ap == pytest.approx(100.0) and by_bin[(10.0, "bev")].detections == 0
    assert by_bin[(20.0, "bev")].ap == pytest.approx(100.0) and by_bin[(20.0, "bev")].detections == 100
    ghost = player(0.0, -10.0)  # 25 m, no box there
    noisy = [(s, found(np.concatenate([d.boxes[:, -1], ghost[None]]), [0.9, 0.8, 0.95])) for s, d in results]
    by_bin = rows_of(ap_by_distance(noisy, SENSOR, 10.0))
    assert by_bin[(10.0, "bev")].ap == pytest.approx(100.0)
    assert by_bin[(20.0, "bev")].ap < 100.0


def test_one_bin_over_everything_is_the_plain_ap():
    rng = np.random.default_rng(3)
    results = []
    for index in range(40):
        truth = np.stack([player(*xy) for xy in rng.uniform([-30, -30], [30, 30], (8, 2))])
        jitter = truth + np.concatenate([rng.normal(0, 0.15, (8, 2)), np.zeros((8, 5))], axis=1).astype(np.float32)
        keep = rng.random(8) < 0.8
        extra = np.stack([player(*xy) for xy in rng.uniform([-30, -30], [30, 30], (2, 2))])
        results.append((sample(truth, index + 2),
                        found(np.concatenate([jitter[keep], extra]), rng.random(int(keep.sum()) + 2))))
    whole = rows_of(ap_by_distance(results, SENSOR, 1000.0))
    plain = average_precisions(results)
    assert list(whole) == [(0.0, "bev"), (0.0, "3d")]
    for kind in ("bev", "3d"):
        assert whole[(0.0, kind)].ap == pytest.approx(mean_ap(plain, kind))
    assert 0.0 < whole[(0.0, "3d")].ap < 100.0


def test_points_columns_are_of_the_boxes_at_t_in_the_bin():
    truth = np.stack([player(0.0, -30.0), player(0.0, -31.0), player(0.0, -10.0)])
    results = [(sample(truth), found(truth, [0.9, 0.8, 0.7]))]
    points = [np.array([[0, 0, 4], [9, 9, 0], [1, 0, 0]])]  # t-2, t-1, t per object
    by_bin = rows_of(ap_by_distance(results, SENSOR, 10.0, points))
    near, far = by_bin[(0.0, "3d")], by_bin[(20.0, "3d")]
    assert (near.median_points, near.seen_t, near.seen_window) == (2.0, 0.5, 1.0)
    assert (far.median_points, far.seen_t, far.seen_window) == (0.0, 0.0, 1.0)
    bare = rows_of(ap_by_distance(results, SENSOR, 10.0))[(0.0, "3d")]
    assert np.isnan([bare.median_points, bare.seen_t, bare.seen_window]).all()


def test_unmatched_detections_marked_ignore_unmatched_leave_the_ranking():
    """A false positive scored above every hit halves nothing once it is marked: matched ones still count."""
    truth = np.stack([player(3.0 * i, 0.0) for i in range(50)])
    ghost = player(0.0, 20.0)
    detected = np.concatenate([truth, ghost[None]])
    scores = np.concatenate([np.linspace(0.9, 0.2, 50), [0.99]]).astype(np.float32)
    plain = FrameBoxes(detected, scores, truth)
    marked = FrameBoxes(detected, scores, truth, ignore_unmatched=np.ones(51, bool))
    assert detection_ap([plain], "bev") < 100.0
    assert detection_ap([marked], "bev") == pytest.approx(100.0)


def test_zones_split_the_boxes_at_the_papers_box_edge():
    """Players inside the paper's [-40, 40] m box (one on its edge) and beyond it: each counts in one zone; a false
    detection beyond the box lowers only the outside zone's AP."""
    truth = np.stack([player(0.0, 0.0), player(40.0, 10.0), player(45.0, 0.0), player(-50.0, 30.0)])
    false = player(-48.0, -20.0)
    results = [(sample(truth), found(np.concatenate([truth, false[None]]), [0.5, 0.5, 0.5, 0.5, 0.9]))
               for _ in range(60)]
    rows = {(r.zone, r.iou): r for r in ap_by_zone(results) if r.recall_points == 40}
    assert sorted(rows) == [("outside", "3d"), ("outside", "bev"), ("paper box", "3d"), ("paper box", "bev")]
    assert rows[("paper box", "3d")].truth == rows[("outside", "3d")].truth == 120
    assert rows[("paper box", "3d")].detections == 120 and rows[("outside", "3d")].detections == 180
    assert rows[("paper box", "3d")].ap == pytest.approx(100.0)
    assert rows[("outside", "3d")].ap < 100.0
