"""The metrics from frames logged to disk chunk by chunk (train.evaluation.frame_log, what `track` uses, memory flat
in a run's length) equal those computed in memory on the same frames."""

from __future__ import annotations

import numpy as np
import pytest

from tests.support.trackers import AB3DMOT, FULL_TRACKER, shipped_tracker
from tests.support.tracking_clips import NOISY_DETECTOR, PlayersConfig, make_tracklets, simulate_players
from train.evaluation.frame_log import CHUNK_FRAMES, FrameLog, _Switches
from train.evaluation.hota import centre_hota, hota
from train.evaluation.tracking import evaluate_tracking, switches_and_fragments
from train.tracking.clip import make_tracker, track_clip


def test_switches_fed_frame_by_frame_count_as_along_whole_trajectories():
    """IDS and FRAG of random trajectories (ids from a few, often untracked), interleaved frame by frame."""
    rng = np.random.default_rng(3)
    trajectories = [rng.choice([-1, 0, 1, 2], size=rng.integers(1, 30)).tolist() for _ in range(200)]
    switches = _Switches()
    for step in range(30):
        for key, assigned in enumerate(trajectories):
            if step < len(assigned):
                switches.see((0, key), assigned[step])
    expected = np.sum([switches_and_fragments(t) for t in trajectories], axis=0)
    assert expected.min() > 0
    assert switches.counts() == tuple(expected)


@pytest.mark.parametrize("tracker", [FULL_TRACKER, AB3DMOT])
def test_logged_metrics_equal_the_metrics_in_memory(tmp_path, tracker):
    """Two clips over chunk boundaries (250 and 130 frames, chunks of 100), noisy tracklets."""
    truth, tracks = [], []
    for seed, frames in ((0, 2 * CHUNK_FRAMES + 50), (1, CHUNK_FRAMES + 30)):
        clip = simulate_players(PlayersConfig(n_players=12, n_frames=frames), np.random.default_rng(seed))
        tracklets = make_tracklets(clip, NOISY_DETECTOR, np.random.default_rng(seed + 5))
        truth.append(clip.frames())
        tracks.append(track_clip(make_tracker(shipped_tracker(tracker)), tracklets))
    log = FrameLog(tmp_path / "log")
    for gt_clip, track_clip_ in zip(truth, tracks):
        log.start_clip()
        for gt, tracked in zip(gt_clip, track_clip_):
            log.add(gt, tracked)
        log.end_clip()
    logged = log.evaluate_tracking()
    expected = evaluate_tracking(truth, tracks)
    counts = ("n_gt", "tp", "fp", "fn", "ids", "frag")
    assert [getattr(logged.best, name) for name in counts] == [getattr(expected.best, name) for name in counts]
    assert logged.best.iou_sum == pytest.approx(expected.best.iou_sum, rel=1e-12)
    assert (logged.samota, logged.amota, logged.best_threshold, logged.levels_reached) == (
        expected.samota, expected.amota, expected.best_threshold, expected.levels_reached)
    assert logged.amotp == pytest.approx(expected.amotp, rel=1e-12)
    for mine, theirs in ((log.hota(), hota(truth, tracks)), (log.centre_hota(), centre_hota(truth, tracks))):
        assert (mine.hota, mine.deta, mine.assa, mine.loca) == pytest.approx(
            (theirs.hota, theirs.deta, theirs.assa, theirs.loca), rel=1e-12)
        np.testing.assert_allclose(mine.hota_per_alpha, theirs.hota_per_alpha, rtol=1e-12)
    log.remove()
    assert not (tmp_path / "log").exists()
