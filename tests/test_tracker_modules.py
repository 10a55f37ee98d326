"""The accounting of the tracker's birth/death and split modules (train.evaluation.tracker_modules), scripted clips."""

import numpy as np

from tests.support.trackers import BIRTH_DEATH, DIOU, FULL_TRACKER, shipped_tracker
from train.evaluation.tracker_modules import (
    ClosePairs,
    ModuleCounts,
    box_labels,
    close_pairs,
    count_clip,
    count_modules,
)
from train.tracking.tracker import Tracker
from train.tracking.types import GroundTruthFrame, Tracklets

PLAYER = np.array([0.0, 0.0, 0.9, 0.6, 0.8, 1.8, 0.0])
FRAMES = 20


def at(x: float, y: float) -> np.ndarray:
    return PLAYER + [x, y, 0, 0, 0, 0, 0]


def still(box: np.ndarray) -> np.ndarray:
    """A standing player's tracklet (3, 7)."""
    return np.repeat(box[None], 3, axis=0)


def clip(players: dict[int, np.ndarray], seen: dict[int, set[int]], extra: dict[int, list[np.ndarray]]
         ) -> tuple[list[Tracklets], list[GroundTruthFrame]]:
    """Standing players (id -> box), each detected in the frames `seen` gives (all by default), plus extra
    tracklets (3, 7) per frame; the labels are the players in every frame."""
    frames, truth = [], []
    for f in range(FRAMES):
        boxes = [still(b) for i, b in players.items() if f in seen.get(i, range(FRAMES))] + extra.get(f, [])
        frames.append(Tracklets(np.array(boxes).reshape(-1, 3, 7), np.full(len(boxes), 0.9)))
        truth.append(GroundTruthFrame(np.array(list(players.values())), np.array(list(players), np.int64)))
    return frames, truth


def test_box_labels_take_the_most_overlapped_label_at_iou_a_quarter():
    truth = GroundTruthFrame(np.array([at(0, 0), at(5, 0)]), np.array([7, 9]))
    labels = box_labels(np.array([at(0.05, 0), at(5, 0.1), at(20, 0), at(0, 0.6)]), truth)
    assert labels.tolist() == [7, 9, -1, -1]


def test_a_false_tracklet_is_a_birth_held_back_and_a_duplicate_too():
    frames, truth = clip({1: at(0, 0)}, {}, {5: [still(at(30, 0))], 9: [still(at(0.05, 0.02))]})
    counts = count_clip(Tracker(shipped_tracker(BIRTH_DEATH)), frames, truth)
    assert (counts.held_back, counts.held_back_false, counts.held_back_duplicate, counts.held_back_real) == (2, 1, 1, 0)
    assert (counts.confirmed, counts.confirmed_real) == (1, 1)


def test_a_missed_player_is_output_while_dying_and_recovered_on_himself():
    frames, truth = clip({1: at(0, 0), 2: at(10, 0)}, {1: set(range(FRAMES)) - {8, 9}}, {})
    counts = count_clip(Tracker(shipped_tracker(BIRTH_DEATH)), frames, truth)
    assert (counts.dying_output, counts.dying_output_useful, counts.dying_output_off) == (2, 2, 0)
    assert (counts.dying_recovered, counts.recovered_same, counts.recovered_other, counts.dying_died) == (1, 1, 0, 0)


def test_a_player_lost_for_good_dies_after_the_dying_frames():
    frames, truth = clip({1: at(0, 0)}, {1: set(range(8))}, {})
    counts = count_clip(Tracker(shipped_tracker(BIRTH_DEATH)), frames, truth)
    assert counts.dying_died == 1 and counts.dying_output == shipped_tracker(BIRTH_DEATH).life_cycle.max_misses


def test_a_fused_pair_is_split_into_two_players():
    a, b = at(0, 0), at(0, 0.6)
    fused = {f: [still(at(0, 0.3))] for f in range(10, 14)}
    frames, truth = clip({1: a, 2: b}, {1: set(range(10)) | set(range(14, FRAMES)),
                                        2: set(range(10)) | set(range(14, FRAMES))}, fused)
    counts = count_clip(Tracker(shipped_tracker(FULL_TRACKER)), frames, truth)
    assert counts.splits >= 1 and counts.split_two_players == counts.splits
    assert count_clip(Tracker(shipped_tracker(BIRTH_DEATH)), frames, truth).splits == 0


def test_a_tracker_without_birth_and_death_holds_nothing_back_and_counts_add_over_clips():
    frames, truth = clip({1: at(0, 0)}, {}, {5: [still(at(30, 0))]})
    assert count_clip(Tracker(shipped_tracker(DIOU)), frames, truth) == ModuleCounts()
    once = count_clip(Tracker(shipped_tracker(BIRTH_DEATH)), frames, truth)
    assert count_modules(shipped_tracker(BIRTH_DEATH), [frames, frames], [truth, truth]) == once + once


def test_close_pairs_tell_separate_fused_and_missed_players():
    a, b, far = at(0, 0), at(0, 0.6), at(20, 0)
    truth = [GroundTruthFrame(np.array([a, b, far]), np.array([1, 2, 3]))] * 4
    shown = [[a, b], [at(0, 0.3)], [a], []]  # separate, fused at the midpoint, one alone, none
    frames = [Tracklets(np.array([still(x) for x in boxes]).reshape(-1, 3, 7), np.full(len(boxes), 0.9))
              for boxes in shown]
    assert close_pairs(frames, truth) == ClosePairs(pairs=4, separate=1, fused=1, one=1, none=1)
