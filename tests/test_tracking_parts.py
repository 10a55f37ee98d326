"""The trackers' pieces: Kalman filter, pruned DIoU affinity and matching, life cycle, split, synthetic clips."""

import numpy as np
import pytest

from tests.support.tracking_clips import DetectionNoise, PlayersConfig, fuse_boxes, make_tracklets, simulate_players
from train.geometry import diou_3d
from train.tracking import life_cycle, motion_model
from train.tracking.association import diou_affinity, diou_upper_bound, match
from train.tracking.life_cycle import LifeCycleConfig
from train.tracking.motion_model import KalmanConfig, KalmanState
from train.tracking.split import SplitConfig, axis_gap, axis_mean, find_fusions, split_boxes

PLAYER = np.array([0.0, 0.0, 0.9, 0.6, 0.8, 1.8, 0.0])


def player(x=0.0, y=0.0, yaw=0.0) -> np.ndarray:
    return PLAYER + [x, y, 0, 0, 0, 0, yaw]


def random_players(rng: np.random.Generator, n: int, spread_m: float) -> np.ndarray:
    boxes = np.tile(PLAYER, (n, 1))
    boxes[:, :2] = rng.uniform(-spread_m, spread_m, (n, 2))
    boxes[:, 3:6] += rng.uniform(-0.1, 0.1, (n, 3))
    boxes[:, 6] = rng.uniform(-np.pi, np.pi, n)
    return boxes


# Kalman filter


def reference_update(mean, covariance, box, config):
    """One textbook Kalman update with explicit matrices, measuring box (x, y, z, l, w, h, yaw)."""
    h = np.eye(7, 10)
    z = box[[0, 1, 2, 6, 3, 4, 5]]
    innovation = z - h @ mean
    innovation[3] = (innovation[3] + np.pi / 2) % np.pi - np.pi / 2
    s = h @ covariance @ h.T + config.measurement_variance * np.eye(7)
    gain = covariance @ h.T @ np.linalg.inv(s)
    return mean + gain @ innovation, (np.eye(10) - gain @ h) @ covariance


def test_kalman_update_matches_the_textbook_equations():
    rng = np.random.default_rng(0)
    config = KalmanConfig()
    mean = rng.normal(size=(5, 10))
    mean[:, 3] = rng.uniform(-1, 1, 5)
    root = rng.normal(size=(5, 10, 10))
    covariance = root @ root.transpose(0, 2, 1) + np.eye(10)
    boxes = rng.normal(size=(5, 7))
    got = motion_model.update(KalmanState(mean, covariance), boxes, config)
    for k in range(5):
        want_mean, want_cov = reference_update(mean[k], covariance[k], boxes[k], config)
        want_mean[3] = (want_mean[3] + np.pi) % (2 * np.pi) - np.pi
        np.testing.assert_allclose(got.mean[k], want_mean, atol=1e-9)
        np.testing.assert_allclose(got.covariance[k], want_cov, atol=1e-9)


def test_kalman_learns_a_constant_velocity_and_ignores_a_flipped_box():
    config = motion_model.PLAYER_KALMAN
    state = motion_model.init_state(np.array([player()]), config)
    for frame in range(1, 30):
        state = motion_model.predict(state, config)
        box = player(x=0.5 * frame, y=-0.2 * frame, yaw=np.pi * (frame % 2))  # yaw + pi: the same box
        state = motion_model.update(state, box[None], config)
    np.testing.assert_allclose(state.mean[0, 7:9], [0.5, -0.2], atol=1e-3)
    np.testing.assert_allclose(state.mean[0, 3], 0.0, atol=1e-6)
    predicted = motion_model.state_boxes(motion_model.predict(state, config))[0]
    np.testing.assert_allclose(predicted[:2], [15.0, -6.0], atol=1e-2)


# Association


@pytest.mark.parametrize("spread_m", [1.0, 5.0, 50.0])
def test_pruned_affinity_is_exact_where_it_can_match(spread_m):
    rng = np.random.default_rng(int(spread_m))
    tracklets = np.stack([random_players(rng, 22, spread_m) for _ in range(2)], axis=1)  # (22, 2, 7)
    trajectories = tracklets[rng.permutation(22)] + rng.normal(0, 0.3, (22, 2, 7)) * [1, 1, 0, 0, 0, 0, 1]
    weights = (0.4, 0.6)
    full = weights[0] * diou_3d(tracklets[:, 0], trajectories[:, 0]) + weights[1] * diou_3d(
        tracklets[:, 1], trajectories[:, 1]
    )
    for bound in (-0.125, -0.5, np.linspace(-0.6, -0.1, 22)):
        got = diou_affinity(tracklets, trajectories, weights, bound)
        reachable = full >= bound
        np.testing.assert_allclose(got[reachable], full[reachable], atol=1e-12)
        assert np.all(got[~reachable] < np.broadcast_to(bound, full.shape)[~reachable])


def test_diou_upper_bound_bounds_diou():
    rng = np.random.default_rng(3)
    a, b = random_players(rng, 60, 3.0), random_players(rng, 60, 3.0)
    a[:, 3:6] = rng.uniform(0.1, 3.0, (60, 3))
    assert np.all(diou_upper_bound(a[:, None], b[None]) >= diou_3d(a, b) - 1e-12)


def test_match_keeps_pairs_at_or_above_the_bound_and_maximises_the_margin():
    affinity = np.array([[0.9, -0.1], [-0.12, -np.inf]])
    rows, cols = match(affinity, -0.125)
    # Both pairs A-2, B-1 reach the bound, but A-1 alone has the larger margin: 1.025 > 0.025 + 0.005.
    assert list(zip(rows, cols)) == [(0, 0)]
    rows, cols = match(np.array([[-0.2, -0.3]]), -0.125)
    assert len(rows) == 0
    rows, cols = match(np.array([[-0.125, 0.5], [0.2, -1.0]]), -0.125)
    assert sorted(zip(rows, cols)) == [(0, 1), (1, 0)]
    assert len(match(np.empty((0, 3)), -0.125)[0]) == 0


# Life cycle


def test_life_cycle_births_and_deaths():
    rules = LifeCycleConfig(birth_death=True, min_hits=3, max_misses=2, tentative_max_misses=0)
    hits, misses = np.array([1, 2, 5, 5]), np.array([0, 0, 1, 2])
    hits, misses = life_cycle.count_frame(hits, misses, np.array([False, True, False, False]))
    assert hits.tolist() == [1, 3, 5, 5] and misses.tolist() == [1, 0, 2, 3]
    assert life_cycle.confirmed(hits, rules).tolist() == [False, True, True, True]
    assert life_cycle.survives(hits, misses, rules).tolist() == [False, True, True, False]
    ab3dmot = rules.model_copy(update={"tentative_max_misses": 2})  # AB3DMOT: tentative tracks live as long
    assert life_cycle.survives(hits, misses, ab3dmot).tolist() == [True, True, True, False]
    without = rules.model_copy(update={"birth_death": False})  # every track output at once, ended by a miss
    assert life_cycle.confirmed(np.array([1, 2]), without).all()
    assert life_cycle.survives(hits, misses, without).tolist() == [False, True, False, False]


# Split


def test_axis_mean_and_gap():
    mean, agreement = axis_mean(np.array([0.2, 0.0, 0.0]), np.array([0.4, np.pi, np.pi / 2]))
    np.testing.assert_allclose(mean[:2], [0.3, 0.0], atol=1e-12)
    np.testing.assert_allclose(agreement, [np.cos(0.2), 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(axis_gap(np.array([0.1, 3.0]), np.array([np.pi, 0.0])), [0.1, np.pi - 3.0])


def fusions(fused, partner, orphan, was_matched=True, still_fused=False):
    return find_fusions(
        np.array([fused]),
        np.array([partner]),
        np.array([orphan]),
        np.array([was_matched]),
        np.array([[still_fused]]),
        SplitConfig(),
    )


def test_find_fusions():
    a, b = player(x=-0.3, yaw=0.1), player(x=0.3, yaw=0.3)
    midpoint = fuse_boxes(a, b)
    assert [x.tolist() for x in fusions(midpoint, a, b)] == [[0], [0]]
    assert len(fusions(a, a, b)[0]) == 0  # the partner's own detection: the orphan was just missed
    assert len(fusions(midpoint, a, b, was_matched=False)[0]) == 0  # lost earlier: maybe a duplicate
    assert len(fusions(midpoint, a, player(x=-0.2))[0]) == 0  # too close to be two bodies
    assert len(fusions(midpoint, a, player(x=2.0))[0]) == 0  # too far apart to be fused
    assert len(fusions(player(x=0.0, yaw=1.4), a, b)[0]) == 0  # heading unlike the pair's
    near_partner = player(x=-0.1, yaw=1.4)
    assert len(fusions(near_partner, a, b)[0]) == 0
    assert len(fusions(near_partner, a, b, was_matched=False, still_fused=True)[0]) == 1  # a split pair stays


def test_split_boxes_keep_a_slow_pair_and_move_a_passing_one():
    fused = player(x=5.0, y=1.0)[None]
    previous = np.array([[player(x=4.7), player(x=5.3)]])
    slow = np.array([[player(x=4.8), player(x=5.2)]])  # closing 0.2 m in a frame
    boxes = split_boxes(fused, previous, slow, SplitConfig())
    np.testing.assert_allclose(boxes[0, :, :2], [[4.7, 1.0], [5.3, 1.0]])
    passing = np.array([[player(x=5.2), player(x=4.8)]])  # 1 m in a frame: running past each other
    boxes = split_boxes(fused, previous, passing, SplitConfig())
    np.testing.assert_allclose(boxes[0, :, :2], [[5.2, 1.0], [4.8, 1.0]])


# Synthetic clips


@pytest.fixture(scope="module")
def clip():
    return simulate_players(PlayersConfig(n_frames=300, meetings=2, crossings=2), np.random.default_rng(7))


def test_players_move_like_players(clip):
    config = PlayersConfig()
    boxes = clip.boxes
    speed = np.linalg.norm(np.diff(boxes[:, :, :2], axis=0), axis=-1) * config.frame_rate_hz
    assert speed.max() <= config.max_speed_mps + 0.5
    assert np.all(np.abs(boxes[..., :2]) <= np.array(config.pitch_m) / 2)
    np.testing.assert_allclose(boxes[..., 2], boxes[..., 5] / 2)
    assert len(np.unique(boxes[0, :, :2], axis=0)) == config.n_players
    again = simulate_players(PlayersConfig(n_frames=300, meetings=2, crossings=2), np.random.default_rng(7))
    np.testing.assert_array_equal(again.boxes, boxes)


def test_encounters_bring_players_together(clip):
    assert sorted(e.kind for e in clip.encounters) == ["crossing", "crossing", "meeting", "meeting"]
    for encounter in clip.encounters:
        i, j = encounter.players
        gap = np.linalg.norm(
            clip.boxes[encounter.start_frame :, i, :2] - clip.boxes[encounter.start_frame :, j, :2], axis=1
        )
        if encounter.kind == "meeting":
            assert np.count_nonzero(np.abs(gap - 0.4) < 0.05) >= 5  # standing together
        else:
            assert 0.2 < gap.min() < 0.5


def test_exact_tracklets_are_the_ground_truth(clip):
    tracklets = make_tracklets(clip, DetectionNoise(), np.random.default_rng(0))
    for frame in (0, 1, 150):
        past = [max(frame - 2, 0), max(frame - 1, 0), frame]
        np.testing.assert_array_equal(tracklets[frame].boxes, clip.boxes[past].transpose(1, 0, 2))


def test_fused_tracklet_is_the_average_of_the_pair(clip):
    meeting = next(e for e in clip.encounters if e.kind == "meeting")
    i, j = meeting.players
    gap = np.linalg.norm(clip.boxes[:, i, :2] - clip.boxes[:, j, :2], axis=1)
    frame = int(np.flatnonzero((gap < 0.5) & (np.arange(len(gap)) >= meeting.start_frame))[0])
    tracklets = make_tracklets(clip, DetectionNoise(fuse_distance_m=0.8), np.random.default_rng(0))[frame]
    assert len(tracklets.boxes) == clip.boxes.shape[1] - 1
    expected = fuse_boxes(clip.boxes[frame - 2 : frame + 1, i], clip.boxes[frame - 2 : frame + 1, j])
    assert np.any(np.all(np.isclose(tracklets.boxes, expected), axis=(1, 2)))
    np.testing.assert_allclose(
        expected[:, :2], (clip.boxes[frame - 2 : frame + 1, i, :2] + clip.boxes[frame - 2 : frame + 1, j, :2]) / 2
    )


def test_noise_misses_and_false_tracklets(clip):
    noise = DetectionNoise(
        centre_sigma_m=0.1, miss_prob=0.1, miss_mean_frames=3.0, false_per_frame=2.0, duplicate_prob=0.1
    )
    tracklets = make_tracklets(clip, noise, np.random.default_rng(0))
    counts = np.array([len(t.scores) for t in tracklets])
    n_players = clip.boxes.shape[1]
    # Missed: a run starts with 0.1 and lasts 3 frames on average, so a quarter of the time
    # (0.1 * 3 / (1 + 0.1 * 3)); false: 2 per frame plus 10 % duplicates of the detected.
    expected = n_players * (1 - 0.3 / 1.3) * 1.1 + 2.0
    assert abs(counts.mean() - expected) < 1.0
    low = np.concatenate([t.scores for t in tracklets]) < 0.6
    assert abs(low.mean() - (expected - n_players * (1 - 0.3 / 1.3)) / expected) < 0.03
