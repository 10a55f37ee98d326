"""Trackers as config files (train/configs/tracking/) and the tracklet filter that feeds them."""

import numpy as np
import pytest
import yaml

from simgen.errors import UserError
from tests.support.trackers import FULL_TRACKER
from tests.support.tracking_clips import (
    FLOOD,
    PlayersConfig,
    make_tracklets,
    simulate_players,
)
from train.detector.nms import nms_bev, nms_centre
from train.study.run import TRACKER_CONFIGS
from train.study.tracklet_filter import TrackletFilter, apply_filter, choose_filters, filter_tracklets
from train.tracking.clip import make_tracker
from train.tracking.config import load_tracker_config, load_tracker_configs
from train.tracking.motion_model import PLAYER_KALMAN, KalmanConfig
from train.tracking.tracker import Tracker
from train.tracking.types import Tracklets

PLAYER = np.array([0.0, 0.0, 0.9, 0.6, 0.8, 1.8, 0.0])


def test_the_shipped_configs_are_the_papers_table_2_rows():
    configs = load_tracker_configs(TRACKER_CONFIGS)
    names = [c.name for c in configs]
    assert names == [
        "AB3DMOT", "AB3DMOT (player Kalman)", "3D DIoU", "3D DIoU + split", "3D DIoU + birth/death", FULL_TRACKER,
    ]
    assert all(isinstance(make_tracker(c), Tracker) for c in configs)
    ab3dmot = [(c.association.cascade, c.life_cycle.warm_up, c.output) for c in configs[:2]]
    assert ab3dmot == [(False, True, "kalman")] * 2  # AB3DMOT: one matching, its warm-up, the filter's boxes
    assert {(c.association.cascade, c.life_cycle.warm_up, c.output) for c in configs[2:]} == {(True, False, "tracklet")}


def test_ab3dmot_with_the_player_kalman_differs_from_ab3dmot_only_in_its_motion_model():
    """AB3DMOT's own row keeps its KITTI-car variances (exact against its evaluation); the added row has AB3DMOT's
    association and life cycle with the motion model of every 3D DIoU row."""
    configs = {c.name: c for c in load_tracker_configs(TRACKER_CONFIGS)}
    ab3dmot, player = configs["AB3DMOT"], configs["AB3DMOT (player Kalman)"]
    assert ab3dmot.motion_model == "kalman_ab3dmot" and player.motion_model == "kalman_player"
    assert {c.motion_model for name, c in configs.items() if name.startswith("3D DIoU")} == {"kalman_player"}
    assert player.model_copy(update={"name": ab3dmot.name, "motion_model": ab3dmot.motion_model}) == ab3dmot
    assert make_tracker(player).kalman == PLAYER_KALMAN != make_tracker(ab3dmot).kalman


def test_the_shipped_files_hold_the_papers_and_ab3dmots_values():
    """The full tracker's file has the paper's values (Sect. 4.1); AB3DMOT's has AB3DMOT's defaults (IoU >= 0.01,
    3 hits, every track dead at max_age 2 misses, its KITTI-car variances). The trackers run on the validated
    config itself: no other config type to rename its fields into."""
    configs = {c.name: c for c in load_tracker_configs(TRACKER_CONFIGS)}
    full, ab3dmot = configs[FULL_TRACKER], configs["AB3DMOT"]
    association, life = full.association, full.life_cycle
    assert (association.lower_bound, association.dying_lower_bound, association.weights) == (-0.125, -0.5, (0.4, 0.6))
    assert (life.min_hits, life.max_misses, life.tentative_max_misses, life.backfill, life.output_dying) == (
        3, 6, 0, True, True,
    )
    assert full.split and full.motion_model == "kalman_player"
    life = ab3dmot.life_cycle
    assert ab3dmot.association.lower_bound == 0.01
    assert (life.min_hits, life.max_misses, life.tentative_max_misses) == (3, 1, 1)
    assert make_tracker(ab3dmot).kalman == KalmanConfig()
    for config in configs.values():
        assert make_tracker(config).config is config


@pytest.mark.parametrize(
    "change, message",
    [
        ({"split": True}, "'split': needs association.method tracklet_diou"),
        ({"life_cycle": {"birth_death": True, "backfill": True}}, "'life_cycle.backfill': needs association.method"),
        ({"life_cycle": {"birth_death": False}}, "'life_cycle.birth_death': AB3DMOT (iou_3d) always has it"),
        ({"motion_model": "constant_acceleration"}, "'motion_model'"),
        ({"association": {"method": "iou_3d", "lower_bound": 0.01, "gate": 2}}, "unknown key 'association.gate'"),
        ({"life_cycle": {"birth_death": True, "min_hits": 0}}, "'life_cycle.min_hits'"),
    ],
)
def test_bad_tracker_configs_are_one_line_errors(tmp_path, change, message):
    data = yaml.safe_load((TRACKER_CONFIGS / "1_ab3dmot.yaml").read_text())
    data.update(change)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(UserError) as error:
        load_tracker_config(path)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_folder_without_configs_or_with_twin_names_is_refused(tmp_path):
    with pytest.raises(UserError, match="no tracker configs"):
        load_tracker_configs(tmp_path)
    for name in ("a.yaml", "b.yaml"):
        (tmp_path / name).write_text((TRACKER_CONFIGS / "2_diou.yaml").read_text())
    with pytest.raises(UserError, match="share a name"):
        load_tracker_configs(tmp_path)


def boxes_at(*xs: float) -> np.ndarray:
    return np.array([PLAYER + [x, 0, 0, 0, 0, 0, 0] for x in xs])


def test_centre_nms_and_bev_iou_nms():
    boxes, scores = boxes_at(0.0, 0.5, 0.9, 3.0), np.array([0.5, 0.9, 0.4, 0.8])
    # Best first: 0.5 (0.9), 3.0 (0.8); 0.0 and 0.9 are within 0.6 m of 0.5.
    assert nms_centre(boxes, scores, 0.6, 10).tolist() == [1, 3]
    assert nms_centre(boxes, scores, 0.3, 10).tolist() == [1, 3, 0, 2]
    # BEV IoU: 0.6 m long boxes 0.5 m apart overlap (IoU 1/11 > 0.01), 0.4 m apart more.
    assert nms_bev(boxes, scores, 0.01, 10).tolist() == [1, 3]
    assert nms_bev(boxes, scores, 0.2, 10).tolist() == [1, 3, 0, 2]
    assert nms_centre(boxes, scores, 0.6, 1).tolist() == [1]


def test_filter_keeps_scores_at_or_above_then_suppresses_on_the_boxes_at_t():
    tracklets = np.stack([boxes_at(9.0, 9.0, x) for x in (0.0, 0.5, 3.0, 6.0)])  # differ only at t
    scores = np.array([0.5, 0.9, 0.3, 0.29])
    assert filter_tracklets(tracklets, scores, TrackletFilter(0.3, "centre", 1.0)).tolist() == [1, 2]
    assert filter_tracklets(tracklets, scores, TrackletFilter(0.0, "bev_iou", 0.2)).tolist() == [1, 0, 2, 3]
    assert len(filter_tracklets(tracklets, scores, TrackletFilter(0.95, "centre", 1.0))) == 0
    assert TrackletFilter(0.3, "centre", 1.0).label == "score >= 0.3, NMS centres < 1 m"


def test_choose_filter_takes_the_best_samota_on_the_clips_given():
    """A false twin 2 m from each player, scored as high: a tight BEV NMS keeps it, centre NMS at 2.5 m
    removes it, at 20 m it removes players too."""
    clip = simulate_players(PlayersConfig(n_players=8, n_frames=40, meetings=0, crossings=0), np.random.default_rng(2))
    frames = []
    for f in range(40):
        past = clip.boxes[[max(f - 2, 0), max(f - 1, 0), f]].transpose(1, 0, 2)
        twin = past + [0, 2.0, 0, 0, 0, 0, 0]
        frames.append(Tracklets(np.concatenate([past, twin]), np.full(16, 0.9)))
    reference = load_tracker_configs(TRACKER_CONFIGS)[-1]
    grid = [
        TrackletFilter(0.1, "bev_iou", 0.01),
        TrackletFilter(0.1, "centre", 2.5),
        TrackletFilter(0.1, "centre", 20.0),
    ]
    chosen, scores = choose_filters([frames], [clip.frames()], [reference], grid)[reference.name]
    assert chosen == grid[1]
    assert scores[0].tracklets_per_frame > 15 and scores[1].tracklets_per_frame <= 8
    assert scores[1].samota > 0.99 and scores[0].samota < 0.9 and scores[2].samota < 0.9
    assert len(apply_filter(frames, chosen)[20].scores) <= 8
    tie = [grid[1], TrackletFilter(0.2, "centre", 2.5)]
    assert choose_filters([frames], [clip.frames()], [reference], tie)[reference.name][0] == tie[0]  # ties: the earlier


def test_each_tracker_gets_the_filter_it_tracks_best_on_the_train_clips():
    """On a flood of near-duplicates the plain 3D DIoU tracker and the full tracker prefer different filters; each
    gets its own best, the same as when chosen for it alone."""
    clip = simulate_players(PlayersConfig(n_frames=60), np.random.default_rng(10))
    frames = make_tracklets(clip, FLOOD, np.random.default_rng(300))
    trackers = [c for c in load_tracker_configs(TRACKER_CONFIGS) if c.name in ("3D DIoU", FULL_TRACKER)]
    grid = [TrackletFilter(s, kind, value) for s in (0.2, 0.4) for kind, value in (("bev_iou", 0.01), ("centre", 1.0))]
    chosen = choose_filters([frames], [clip.frames()], trackers, grid)
    assert list(chosen) == ["3D DIoU", FULL_TRACKER]
    for tracker in trackers:
        rule, scores = chosen[tracker.name]
        assert [s.rule for s in scores] == grid
        assert rule == max(scores, key=lambda s: s.samota).rule
        assert choose_filters([frames], [clip.frames()], [tracker], grid)[tracker.name] == (rule, scores)
    assert chosen["3D DIoU"][0] != chosen[FULL_TRACKER][0]
