"""The 3D DIoU tracker and AB3DMOT on scripted and synthetic clips, and the paper's ablation."""

import numpy as np
import pytest

from tests.support.trackers import AB3DMOT, BIRTH_DEATH, DIOU, FULL_TRACKER, shipped_tracker
from tests.support.tracking_clips import (
    FLOOD,
    MEDIUM_NOISE,
    NOISY_DETECTOR,
    DetectionNoise,
    PlayersConfig,
    fuse_boxes,
    make_tracklets,
    simulate_players,
)
from train.evaluation.tracking import evaluate_tracking
from train.study.run import TRACKER_CONFIGS
from train.study.tracklet_filter import TrackletFilter, apply_filter, choose_filters
from train.tracking.clip import make_tracker, track_clip
from train.tracking.config import load_tracker_configs
from train.tracking.tracker import Tracker
from train.tracking.types import TrackedFrame, Tracklets

PLAYER = np.array([0.0, 0.0, 0.9, 0.6, 0.8, 1.8, 0.0])


def run(tracker, frames: list[Tracklets]) -> list[TrackedFrame]:
    return [tracker.step(f) for f in frames]


def walker(x0: float, vx: float, frames: range) -> dict[int, np.ndarray]:
    """Tracklets (3, 7) of a player walking along x at vx metres a frame, for the given frames."""
    return {f: np.array([PLAYER + [x0 + vx * t, 0, 0, 0, 0, 0, 0] for t in (f - 2, f - 1, f)]) for f in frames}


def frames_of(*players: dict[int, np.ndarray], n_frames: int) -> list[Tracklets]:
    out = []
    for f in range(n_frames):
        boxes = [p[f] for p in players if f in p]
        out.append(Tracklets(np.array(boxes).reshape(-1, 3, 7), np.full(len(boxes), 0.9)))
    return out


def ids_over_time(out: list[TrackedFrame]) -> list[list[int]]:
    return [sorted(o.ids.tolist()) for o in out]


def test_new_trajectories_are_output_after_three_consecutive_frames():
    flicker = walker(0.0, 0.3, range(2))  # two frames, then gone
    steady = walker(20.0, 0.3, range(5, 12))
    out = run(Tracker(shipped_tracker(FULL_TRACKER)), frames_of(flicker, steady, n_frames=12))
    assert ids_over_time(out) == [[]] * 7 + [[1]] * 5


def test_a_confirmed_trajectory_back_fills_its_first_two_frames_from_its_tracklet():
    steady = walker(20.0, 0.3, range(5, 12))
    out = track_clip(Tracker(shipped_tracker(FULL_TRACKER)), frames_of(steady, n_frames=12))
    assert ids_over_time(out) == [[]] * 5 + [[0]] * 7
    np.testing.assert_array_equal(out[5].boxes[0], steady[7][0])  # the confirming tracklet's box at t-2
    np.testing.assert_array_equal(out[6].boxes[0], steady[7][1])  # and at t-1
    online = run(Tracker(shipped_tracker(FULL_TRACKER)), frames_of(steady, n_frames=12))
    assert len(online[7].backfill) == 2 and ids_over_time(online)[5:7] == [[], []]
    config = shipped_tracker(FULL_TRACKER, life_cycle={"backfill": False})
    no_backfill = track_clip(Tracker(config), frames_of(steady, n_frames=12))
    assert ids_over_time(no_backfill) == [[]] * 7 + [[0]] * 5


def test_a_track_scores_the_mean_of_its_matched_tracklets():
    player = walker(0.0, 0.3, range(8))
    scores = [0.9, 0.3, 0.6, 0.2, 0.8, 0.8, 0.4, 0.4]
    frames = [Tracklets(player[f][None], [scores[f]]) for f in range(8)]
    out = track_clip(Tracker(shipped_tracker(FULL_TRACKER)), frames)
    assert out[0].scores.tolist() == out[1].scores.tolist() == out[2].scores.tolist() == [pytest.approx(0.6)]
    for f in range(3, 8):
        assert out[f].scores[0] == pytest.approx(np.mean(scores[: f + 1]))
    ab = track_clip(Tracker(shipped_tracker(AB3DMOT)), [Tracklets(player[f][None], [scores[f]]) for f in range(8)])
    assert ab[4].scores[0] == pytest.approx(np.mean(scores[:5]))


def test_dying_trajectory_comes_back_within_six_frames():
    gap = set(range(10, 16))  # 6 missed frames
    player = {f: b for f, b in walker(0.0, 0.3, range(30)).items() if f not in gap}
    out = run(Tracker(shipped_tracker(FULL_TRACKER)), frames_of(player, n_frames=30))
    assert ids_over_time(out)[2:] == [[0]] * 28
    # While dying it is output where the Kalman filter carries it: on the walker's line.
    for f in sorted(gap):
        np.testing.assert_allclose(out[f].boxes[0, 0], 0.3 * f, atol=0.05)


def test_dying_trajectory_ends_after_six_frames():
    gap = set(range(10, 17))  # 7 missed frames
    player = {f: b for f, b in walker(0.0, 0.3, range(30)).items() if f not in gap}
    out = run(Tracker(shipped_tracker(FULL_TRACKER)), frames_of(player, n_frames=30))
    assert ids_over_time(out)[16] == [] and ids_over_time(out)[17:19] == [[], []]
    assert ids_over_time(out)[19:] == [[1]] * 11


def test_without_birth_and_death_tracklets_are_output_at_once_and_end_at_once():
    player = {f: b for f, b in walker(0.0, 0.3, range(12)).items() if f != 6}
    out = run(Tracker(shipped_tracker(DIOU)), frames_of(player, n_frames=12))
    assert ids_over_time(out) == [[0]] * 6 + [[]] + [[1]] * 5


def meeting_tracklets(fuse: bool) -> tuple[list[Tracklets], np.ndarray]:
    """Two players walk towards each other, stand 0.5 m apart for 15 frames and walk back.

    Returns the tracklets (one fused box while closer than 0.8 m, when ``fuse``) and the
    players' boxes (T, 2, 7).
    """
    x = np.concatenate([np.linspace(-4.0, -0.25, 16), np.full(15, -0.25), np.linspace(-0.25, -4.0, 16)])
    truth = np.zeros((len(x), 2, 7))
    truth[:, 0], truth[:, 1] = PLAYER, PLAYER
    truth[:, 0, 0], truth[:, 1, 0] = x, -x
    frames = []
    for f in range(len(x)):
        past = truth[[max(f - 2, 0), max(f - 1, 0), f]]  # (3, 2, 7)
        if fuse and abs(2 * x[f]) < 0.8:
            boxes = fuse_boxes(past[:, 0], past[:, 1])[None]
        else:
            boxes = past.transpose(1, 0, 2)
        frames.append(Tracklets(boxes, np.full(len(boxes), 0.9)))
    return frames, truth


def test_split_keeps_both_players_through_a_long_meeting():
    frames, _ = meeting_tracklets(fuse=True)
    out = run(Tracker(shipped_tracker(FULL_TRACKER)), frames)
    first = {int(i): b for i, b in zip(out[5].ids, out[5].boxes)}
    left_id = min(first, key=lambda i: first[i][0])
    for f in range(5, len(frames)):
        assert sorted(out[f].ids.tolist()) == [0, 1]
        left = out[f].boxes[out[f].ids == left_id][0]
        assert left[0] < out[f].boxes[out[f].ids != left_id][0][0]  # the left player stays left
    np.testing.assert_allclose(out[-1].boxes[np.argsort(out[-1].boxes[:, 0]), 0], [-4.0, 4.0], atol=1e-9)

    unsplit = run(Tracker(shipped_tracker(BIRTH_DEATH)), frames)
    assert max(max(o.ids, default=0) for o in unsplit) >= 2  # one of them died and came back new


def test_exact_tracklets_give_no_id_switch_over_a_whole_clip():
    clip = simulate_players(PlayersConfig(n_frames=300, meetings=3, crossings=3), np.random.default_rng(1))
    assert any(e.kind == "meeting" for e in clip.encounters)
    tracklets = make_tracklets(clip, DetectionNoise(), np.random.default_rng(0))
    out = run(Tracker(shipped_tracker(FULL_TRACKER)), tracklets)
    # From frame 2 on, every player is output in every frame, always under the same id.
    for frame, truth in zip(out[2:], clip.boxes[2:]):
        order = np.argsort(frame.ids)
        np.testing.assert_array_equal(frame.ids[order], np.arange(22))
        np.testing.assert_array_equal(frame.boxes[order], truth)
    metrics = evaluate_tracking([clip.frames()], [out])
    assert (metrics.best.ids, metrics.best.frag, metrics.best.fp) == (0, 0, 0)


def test_ab3dmot_life_cycle():
    late = walker(10.0, 0.3, range(5, 20))
    player = {f: b for f, b in walker(0.0, 0.3, range(20)).items() if f not in (8, 12, 13)}
    out = run(Tracker(shipped_tracker(AB3DMOT)), frames_of(player, late, n_frames=20))
    ids = ids_over_time(out)
    assert ids[:3] == [[0]] * 3  # every track is output in the first 3 frames of a clip
    assert ids[5:7] == [[0]] * 2 and ids[7] == [0, 1]  # the late one after 3 hits
    assert ids[8] == [0, 1]  # one miss: still output, predicted
    np.testing.assert_allclose(out[8].boxes[out[8].ids == 0][0, 0], 0.3 * 8, atol=0.05)
    assert ids[12] == [0, 1] and ids[13] == [1]  # two misses: dead
    assert ids[14:16] == [[1]] * 2 and ids[16] == [1, 2]  # back as a new track


@pytest.fixture(scope="module")
def ablation():
    """IDS, FRAG and sAMOTA of each tracker over two noisy clips."""
    configs = {
        "diou": shipped_tracker(DIOU),
        "birth_death": shipped_tracker(BIRTH_DEATH),
        "split": shipped_tracker(FULL_TRACKER),
    }
    clips = [simulate_players(PlayersConfig(n_frames=300), np.random.default_rng(seed)) for seed in (0, 1)]
    tracklets = [make_tracklets(c, NOISY_DETECTOR, np.random.default_rng(100 + i)) for i, c in enumerate(clips)]
    truth = [c.frames() for c in clips]
    results = {}
    for name, config in list(configs.items()) + [("ab3dmot", None)]:
        out = [run(Tracker(shipped_tracker(AB3DMOT) if config is None else config), t) for t in tracklets]
        metrics = evaluate_tracking(truth, out)
        results[name] = (metrics.best.ids, metrics.best.frag, metrics.samota)
    return results


def test_birth_and_death_reduce_fragmentation(ablation):
    assert ablation["birth_death"][1] < 0.5 * ablation["diou"][1]


def test_split_reduces_id_switches_and_fragmentation(ablation):
    assert ablation["split"][0] < 0.7 * ablation["birth_death"][0]
    assert ablation["split"][1] <= ablation["birth_death"][1]


def test_diou_tracker_beats_ab3dmot_on_samota(ablation):
    assert ablation["split"][2] > ablation["ab3dmot"][2]


def samota_by_tracker(clips, tracklets, filters=None) -> dict[str, float]:
    """sAMOTA (IoU 0.25) of every tracker of train/configs/tracking/ over the clips, run as the study runs them:
    each through its own filter of `filters` (tracker name -> TrackletFilter) when given."""
    truth = [c.frames() for c in clips]
    samota = {}
    for config in load_tracker_configs(TRACKER_CONFIGS):
        kept = tracklets if filters is None else [apply_filter(t, filters[config.name]) for t in tracklets]
        samota[config.name] = evaluate_tracking(truth, [track_clip(make_tracker(config), t) for t in kept]).samota
    return samota


def test_medium_noise_gives_the_papers_ordering():
    """The issue's tracklets made from ground truth with medium noise: AB3DMOT < 3D DIoU <= the full tracker + 1."""
    clips = [simulate_players(PlayersConfig(n_frames=150), np.random.default_rng(0))]
    tracklets = [make_tracklets(clips[0], MEDIUM_NOISE, np.random.default_rng(200))]
    samota = samota_by_tracker(clips, tracklets)
    assert samota["AB3DMOT"] < samota["3D DIoU"]
    assert samota[FULL_TRACKER] >= samota["3D DIoU"] - 0.01


@pytest.fixture(scope="module")
def flood():
    """A flood of near-duplicates (about 80 tracklets a frame for 22 players): each tracker's filter chosen by the
    study's rule on a train clip, and every tracker's sAMOTA on another clip, unfiltered and through its filter."""
    clips = [simulate_players(PlayersConfig(n_frames=100), np.random.default_rng(seed)) for seed in (10, 11)]
    tracklets = [make_tracklets(c, FLOOD, np.random.default_rng(300 + i)) for i, c in enumerate(clips)]
    grid = [TrackletFilter(s, kind, value) for s in (0.2, 0.4) for kind, value in (("bev_iou", 0.01), ("centre", 1.0))]
    chosen = choose_filters(tracklets[:1], [clips[0].frames()], load_tracker_configs(TRACKER_CONFIGS), grid)
    raw = samota_by_tracker(clips[1:], tracklets[1:])
    filtered = samota_by_tracker(clips[1:], tracklets[1:], {name: rule for name, (rule, _) in chosen.items()})
    return np.mean([len(f.scores) for f in tracklets[1]]), raw, filtered


def test_a_flood_of_near_duplicates_collapses_birth_and_death(flood):
    per_frame, raw, _ = flood
    assert per_frame > 60
    assert raw[FULL_TRACKER] < raw["3D DIoU"] - 0.3  # confirmed and dying tracks latch onto the duplicates


def test_filtered_flood_gives_the_full_tracker_its_place(flood):
    _, raw, filtered = flood
    assert filtered[FULL_TRACKER] > raw[FULL_TRACKER] + 0.3
    assert filtered[FULL_TRACKER] >= filtered["3D DIoU"] - 0.01


def test_filters_scored_in_processes_are_scored_as_in_one():
    players = simulate_players(PlayersConfig(n_frames=40), np.random.default_rng(12))
    tracklets = [make_tracklets(players, FLOOD, np.random.default_rng(312))]
    grid = [TrackletFilter(s, "centre", 1.0) for s in (0.2, 0.4, 0.6)]
    configs = load_tracker_configs(TRACKER_CONFIGS)[2:4]
    alone = choose_filters(tracklets, [players.frames()], configs, grid)
    assert choose_filters(tracklets, [players.frames()], configs, grid, workers=2) == alone
    assert [len(scores) for _, scores in alone.values()] == [3, 3]


@pytest.mark.parametrize("config", load_tracker_configs(TRACKER_CONFIGS), ids=lambda c: c.name)
def test_a_player_the_engine_places_elsewhere_is_born_again(config):
    """A restart: the player vanishes at x = 0 and walks on from x = 30 m. No tracker links the two (a jump of
    30 m is beyond every association gate): the old track ends, the new place is a new birth, as the
    study's ground truth counts it (`train.study.run.truth_frames`)."""
    before = walker(0.0, 0.3, range(10))
    after = {f: boxes + [30.0, 0, 0, 0, 0, 0, 0] for f, boxes in walker(0.0, 0.3, range(10, 25)).items()}
    after = {f: boxes for f, boxes in after.items() if f >= 12}  # the detector's window no longer spans the jump
    out = track_clip(make_tracker(config), frames_of(before, after, n_frames=25))
    old = {int(i) for frame in out[:10] for i in frame.ids}
    new = {int(i) for frame in out[16:] for i in frame.ids}
    assert len(old) == 1 and len(new) == 1 and not old & new


def test_the_ground_truth_starts_a_new_identity_at_a_placement():
    from train.data import Sample
    from train.study.run import truth_frames

    def sample(t: int, placed: list[bool]) -> Sample:
        return Sample(
            "c", t, (), np.zeros((2, 3, 7), np.float32), np.ones((2, 3), bool), np.array([4, 9]), np.array(placed)
        )

    frames = truth_frames(
        [sample(2, [False, False]), sample(3, [True, False]), sample(4, [False, False]), sample(5, [True, True])]
    )
    assert [f.ids.tolist() for f in frames] == [[0, 1], [2, 1], [2, 1], [3, 4]]
