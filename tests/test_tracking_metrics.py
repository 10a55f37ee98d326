"""train.evaluation: CLEAR MOT, AB3DMOT's averages, HOTA and the KITTI export on hand-worked clips.

Boxes are unit cubes: one on the object gives IoU 1, one shifted by half a metre along x gives
IoU 0.5 / 1.5 = 1/3, one 10 m away gives 0.
"""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from simgen.datasets.formats.kitti import parse_labels
from train.evaluation.hota import centre_hota, centre_similarity, hota
from train.evaluation.kitti import write_kitti_tracking
from train.evaluation.tracking import evaluate_tracking, recall_thresholds, switches_and_fragments
from train.geometry import iou_3d, iou_3d_pairs
from train.tracking.types import GroundTruthFrame, TrackedFrame

CUBE = np.array([0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 0.0])
SHIFTED = CUBE + [0.5, 0, 0, 0, 0, 0, 0]  # IoU 1/3 with CUBE
FAR = CUBE + [10.0, 0, 0, 0, 0, 0, 0]
N_FRAMES = 6


def ground_truth(n_frames: int = N_FRAMES) -> list[GroundTruthFrame]:
    return [GroundTruthFrame([CUBE], [1]) for _ in range(n_frames)]


def tracks(*per_frame: list[tuple[np.ndarray, int]], score: float = 0.9) -> list[TrackedFrame]:
    """Tracker frames from (box, id) lists."""
    return [
        TrackedFrame([b for b, _ in objs] or np.empty((0, 7)), [i for _, i in objs], [score] * len(objs))
        for objs in per_frame
    ]


def best(gt, out, **kwargs):
    return evaluate_tracking([gt], [out], **kwargs).best


def test_perfect_tracker_scores_one():
    rng = np.random.default_rng(0)
    n_objects, n_frames = 22, 50
    centres = rng.uniform(-40, 40, (1, n_objects, 2)) + 0.3 * np.arange(n_frames)[:, None, None]
    boxes = np.concatenate([centres, np.tile([0.9, 0.6, 0.8, 1.8, 0.3], (n_frames, n_objects, 1))], axis=-1)
    ids = np.arange(n_objects) * 3 + 5
    gt = [GroundTruthFrame(b, ids) for b in boxes]
    out = [TrackedFrame(b, ids + 100, np.ones(n_objects)) for b in boxes]
    metrics = evaluate_tracking([gt], [out])
    assert (metrics.samota, metrics.amota, metrics.amotp) == (1.0, 1.0, 1.0)
    assert metrics.levels_reached == 40
    b = metrics.best
    assert (b.mota, b.motp, b.ids, b.frag, b.fp, b.fn) == (1.0, 1.0, 0, 0, 0, 0)
    assert hota([gt], [out]).hota == 1.0


def test_id_switch_counts_one_switch_and_one_fragment():
    out = tracks(*[[(CUBE, 7)]] * 3, *[[(CUBE, 8)]] * 3)
    b = best(ground_truth(), out)
    assert (b.tp, b.fp, b.fn, b.ids, b.frag) == (6, 0, 0, 1, 1)
    assert b.mota == pytest.approx(1 - 1 / 6)


def test_gap_is_a_fragment_and_misses():
    out = tracks([(CUBE, 7)], [(CUBE, 7)], [], [], [(CUBE, 7)], [(CUBE, 7)])
    b = best(ground_truth(), out)
    assert (b.tp, b.fn, b.ids, b.frag) == (4, 2, 0, 1)
    assert b.mota == pytest.approx(1 - 2 / 6)


def test_new_id_after_a_gap_is_no_switch_in_kitti_counting():
    """KITTI counts an ID switch only between two tracked frames in a row."""
    out = tracks([(CUBE, 7)], [(CUBE, 7)], [], [], [(CUBE, 8)], [(CUBE, 8)])
    b = best(ground_truth(), out)
    assert (b.ids, b.frag) == (0, 1)


def test_untracked_object_is_all_misses():
    b = best(ground_truth(), tracks(*[[]] * N_FRAMES))
    assert (b.tp, b.fn, b.fp, b.ids, b.frag, b.mota) == (0, 6, 0, 0, 0, 0.0)


def test_false_track_is_a_false_positive_each_frame():
    out = tracks(*[[(CUBE, 7), (FAR, 9)]] * N_FRAMES)
    metrics = evaluate_tracking([ground_truth()], [out])
    # Both tracks have the same mean score, so no threshold drops the false one.
    assert (metrics.best.tp, metrics.best.fp, metrics.best.mota) == (6, 6, 0.0)


def test_low_scored_false_track_is_dropped_at_the_best_threshold():
    out = [TrackedFrame([CUBE, FAR], [7, 9], [0.9, 0.2]) for _ in range(N_FRAMES)]
    metrics = evaluate_tracking([ground_truth()], [out])
    assert metrics.best_threshold == 0.9
    assert (metrics.best.fp, metrics.best.mota) == (0, 1.0)


def test_duplicate_box_is_one_match_and_one_false_positive():
    out = tracks(*[[(SHIFTED, 7), (CUBE, 9)]] * N_FRAMES)
    b = best(ground_truth(), out)
    assert (b.tp, b.fp, b.ids, b.frag) == (6, 6, 0, 0)
    assert b.motp == 1.0  # the exact box wins every frame


def test_motp_is_the_mean_iou_and_min_iou_gates():
    out = tracks(*[[(SHIFTED, 7)]] * N_FRAMES)
    assert iou_3d_pairs([SHIFTED], [CUBE])[0] == pytest.approx(1 / 3)
    b = best(ground_truth(), out)
    assert (b.tp, b.motp) == (6, pytest.approx(1 / 3))
    b = best(ground_truth(), out, min_iou=0.5)
    assert (b.tp, b.fp, b.fn) == (0, 6, 6)


@pytest.mark.parametrize(
    "assigned, expected",
    [
        ([7, 7, 7, 8, 8, 8], (1, 1)),
        ([7, 8, 7, 7], (2, 2)),
        ([7, 7, -1, 7, 7], (0, 1)),
        ([7, 7, -1, 7, -1], (0, 0)),  # tracking resumed for one frame only is no fragment
        ([-1, 7, 7], (0, 0)),
        ([-1, -1, 7], (0, 1)),  # but the last frame counts any change
        ([7], (0, 0)),
    ],
)
def test_switches_and_fragments_follow_the_kitti_devkit(assigned, expected):
    assert switches_and_fragments(assigned) == expected


def test_recall_thresholds_follow_ab3dmot():
    # Level 0 takes the first score and is dropped, so each level takes the next score.
    assert recall_thresholds([0.6, 0.9, 0.7, 0.8], n_gt=4, levels=4) == [(0.8, 0.25), (0.7, 0.5), (0.6, 0.75)]
    assert recall_thresholds([0.5] * 8, n_gt=8, levels=4) == [(0.5, 0.25), (0.5, 0.5), (0.5, 0.75), (0.5, 1.0)]


def test_averages_count_unreached_levels_as_zero():
    """One object of 6 frames tracked in 3: the true positives reach 3 of 40 levels."""
    out = tracks(*[[(CUBE, 7)]] * 3, *[[]] * 3)
    metrics = evaluate_tracking([ground_truth()], [out])
    assert metrics.levels_reached == 2  # 3 scores, level 0 dropped
    # At every reached level the one track is kept: FN = 3, MOTA = 1/2, sMOTA_r = 1 - (3 - (1-r) 6) / (6 r).
    recalls = [1 / 40, 2 / 40]
    assert metrics.amota == pytest.approx(2 * 0.5 / 40)
    assert metrics.samota == pytest.approx(sum(min(1, max(0, 1 - (3 - (1 - r) * 6) / (6 * r))) for r in recalls) / 40)
    assert metrics.amotp == pytest.approx(2 / 40)


def test_clips_are_evaluated_apart_and_summed():
    one = tracks(*[[(CUBE, 7)]] * 3, *[[(CUBE, 8)]] * 3)
    other = tracks(*[[(CUBE, 8)]] * N_FRAMES)  # id 8 again: a different clip, no switch
    b = evaluate_tracking([ground_truth(), ground_truth()], [one, other]).best
    assert (b.n_gt, b.tp, b.ids) == (12, 12, 1)


def crowded_clip(rng: np.random.Generator, n_frames: int = 30) -> tuple[list[GroundTruthFrame], list[TrackedFrame]]:
    """Four objects side by side; per object and frame a track box near it (often), a duplicate (sometimes),
    ids that switch now and then, and a false box; each track scored at random."""
    gt, out, ids = [], [], [10, 11, 12, 13]
    score = {i: rng.uniform(0.1, 1.0) for i in range(100)}
    for _ in range(n_frames):
        objects = np.array([CUBE + [0.8 * k, 0, 0, 0, 0, 0, 0] for k in range(4)])
        ids = [rng.choice([i, 20 + k]) if rng.random() < 0.1 else i for k, i in enumerate(ids)]
        boxes, track_ids = [], []
        for k, box in enumerate(objects):
            if rng.random() < 0.8:
                boxes.append(box + [rng.normal(0, 0.2), rng.normal(0, 0.2), 0, 0, 0, 0, 0])
                track_ids.append(ids[k])
            if rng.random() < 0.3:
                boxes.append(box + [rng.normal(0, 0.3), 0, 0, 0, 0, 0, 0])
                track_ids.append(30 + k)
        boxes.append(FAR + [rng.normal(0, 0.5), 0, 0, 0, 0, 0, 0])
        track_ids.append(40)
        gt.append(GroundTruthFrame(objects, [1, 2, 3, 4]))
        out.append(TrackedFrame(np.array(boxes), track_ids, [score[i] for i in track_ids]))
    return gt, out


def devkit_counts(gt, out, threshold: float, min_iou: float) -> tuple[tuple[int, ...], list[float]]:
    """(n_gt, tp, fp, ids, frag) and the true positives' scores, frame by frame as the KITTI devkit counts them
    (a track kept or dropped whole by its mean score)."""
    n_gt = tp = fp = 0
    tp_scores, trajectories, per_track = [], {}, {}
    for o in out:
        for track_id, score in zip(o.ids.tolist(), o.scores.tolist()):
            per_track.setdefault(track_id, []).append(score)
    for g, o in zip(gt, out):
        scores = np.array([np.mean(per_track[i]) for i in o.ids.tolist()])
        keep = scores >= threshold
        iou = iou_3d(g.boxes, o.boxes[keep])
        rows, cols = linear_sum_assignment(np.where(iou >= min_iou, 1.0 - iou, 1e9))
        good = iou[rows, cols] >= min_iou
        rows, cols = rows[good], cols[good]
        assigned = np.full(len(g.ids), -1)
        assigned[rows] = o.ids[keep][cols]
        n_gt, tp, fp = n_gt + len(g.ids), tp + len(rows), fp + int(keep.sum()) - len(rows)
        tp_scores += scores[keep][cols].tolist()
        for gt_id, track_id in zip(g.ids.tolist(), assigned.tolist()):
            trajectories.setdefault(gt_id, []).append(track_id)
    ids = sum(switches_and_fragments(a)[0] for a in trajectories.values())
    frag = sum(switches_and_fragments(a)[1] for a in trajectories.values())
    return (n_gt, tp, fp, ids, frag), tp_scores


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("min_iou", [0.25, 0.5])
def test_crowded_clips_count_as_the_devkit_frame_by_frame(seed, min_iou):
    """Duplicates and neighbours make frames where one box could match two objects: the counts, sAMOTA and the
    best MOTA's threshold are the devkit's, frame by frame with the Hungarian algorithm."""
    gt, out = crowded_clip(np.random.default_rng(seed))
    metrics = evaluate_tracking([gt], [out], min_iou=min_iou)
    everything, tp_scores = devkit_counts(gt, out, -np.inf, min_iou)
    levels = recall_thresholds(tp_scores, everything[0])
    samota = 0.0
    for threshold, recall in levels:
        n_gt, tp, fp, ids, _ = devkit_counts(gt, out, threshold, min_iou)[0]
        samota += min(1.0, max(0.0, 1.0 - (n_gt - tp + fp + ids - (1.0 - recall) * n_gt) / (recall * n_gt)))
    b = metrics.best
    assert (b.n_gt, b.tp, b.fp, b.ids, b.frag) == devkit_counts(gt, out, metrics.best_threshold, min_iou)[0]
    assert metrics.samota == pytest.approx(samota / 40, abs=1e-12) and metrics.levels_reached == len(levels)
    assert b.fp > 0 and b.ids + b.frag > 0


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="unique"):
        evaluate_tracking([ground_truth(1)], [tracks([(CUBE, 7), (FAR, 7)])])
    with pytest.raises(ValueError, match="differ"):
        evaluate_tracking([ground_truth(2)], [tracks([(CUBE, 7)])])


def test_hota_hand_cases():
    switch = tracks([(CUBE, 7)], [(CUBE, 7)], [(CUBE, 8)], [(CUBE, 8)])
    # DetA = 1; each match's id pair is right in 2 of the object's 4 frames: AssA = 2 / 4.
    result = hota([ground_truth(4)], [switch])
    assert (result.deta, result.assa, result.hota) == (1.0, 0.5, pytest.approx(np.sqrt(0.5)))
    half = tracks([(CUBE, 7)], [(CUBE, 7)], [], [])
    # DetA = 2 / 4; AssA = TPA / (TPA + FNA + FPA) = 2 / (2 + 2 + 0).
    result = hota([ground_truth(4)], [half])
    assert (result.deta, result.assa, result.hota) == (0.5, 0.5, 0.5)
    shifted = tracks(*[[(SHIFTED, 7)]] * 4)
    # IoU 1/3 reaches alphas 0.05 ... 0.30 (6 of 19): HOTA 1 there, 0 above.
    result = hota([ground_truth(4)], [shifted])
    assert result.hota == pytest.approx(6 / 19)
    assert result.loca == pytest.approx((6 / 3 + 13) / 19)  # LocA is 1 where nothing matched


def test_centre_hota_is_gs_hota_on_the_pitch_plane():
    far = CUBE + np.array([5.0, 0, 3.0, 1.0, 0, 0, 1.0])  # 5 m away on the pitch; height, size, yaw ignored
    np.testing.assert_allclose(centre_similarity(CUBE[None], np.stack([CUBE, far])), [[1.0, 0.05]])
    # Similarity 0.05 at 5 m reaches alpha 0.05 only (1 of 19); the 3D IoU is 0: no match at all.
    result = centre_hota([ground_truth(4)], [tracks(*[[(far, 7)]] * 4)])
    assert result.hota == pytest.approx(1 / 19)
    assert hota([ground_truth(4)], [tracks(*[[(far, 7)]] * 4)]).hota == 0.0
    switch = tracks([(CUBE, 7)], [(CUBE, 7)], [(CUBE, 8)], [(CUBE, 8)])
    assert centre_hota([ground_truth(4)], [switch]).hota == pytest.approx(np.sqrt(0.5))


def test_kitti_export_reads_back_as_a_simgen_kitti_tracking_label(tmp_path):
    boxes = np.array([[10.0, 5.0, 0.9, 0.6, 0.8, 1.8, 0.3], [-52.0, 33.0, 1.0, 0.5, 0.7, 2.0, -2.5]])
    truth, tracked = tmp_path / "truth.txt", tmp_path / "tracked.txt"
    write_kitti_tracking(truth, [GroundTruthFrame(boxes, [3, 4]), GroundTruthFrame(boxes[:1], [3])])
    write_kitti_tracking(tracked, [TrackedFrame(boxes, [3, 4], [0.9, 0.5]), TrackedFrame(boxes[:1], [3], [0.8])])
    labels = parse_labels(truth.read_text(), truth, tracking=True)
    assert labels["frame"].tolist() == [0, 0, 1] and labels["track_id"].tolist() == [3, 4, 3]
    assert labels["class_name"].tolist() == ["Pedestrian"] * 3
    np.testing.assert_allclose(labels["boxes"], np.concatenate([boxes, boxes[:1]]), atol=1e-6)
    rows = [line.split() for line in tracked.read_text().splitlines()]
    assert [row[:17] for row in rows] == [line.split() for line in truth.read_text().splitlines()]
    assert [float(row[17]) for row in rows] == [0.9, 0.5, 0.8]
    heights = [float(row[9]) - float(row[7]) for row in rows]
    assert min(heights) >= 40  # KITTI's devkit drops boxes under 25 px
