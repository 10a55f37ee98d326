"""Restarts: the engine places players in one physics step; nothing is interpolated across it.

The real engine, paper_x1's clip 1 around its first restart: at 9.13 s of game time the engine puts
22 players where the free kick wants them (`simgen verify` once reported them flying at 105-343 m/s).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from simgen.labels.boxes import boxes_from_keypoints
from simgen.motion.clip_io import read_clip, write_clip
from simgen.motion.interpolate import interpolate_clip, segment_index
from simgen.pipeline.clip import engine_seed, render_clip
from simgen.qa.label_checks import in_box
from simgen.scenario import load_scenario, parse_scenario
from simgen.vocab import KEYPOINT_INDEX
from tests.support import ROOT
from tests.support.clips import still_clip
from tests.support.processes import run_simgen

PAPER_X1 = load_scenario(ROOT / "scenarios" / "paper_x1.yaml")
FRAME_RATE_HZ = 11
RESTART = {  # 1.5 s of paper_x1's clip 1 at 100 Hz, its first restart in the middle
    "name": "restart",
    "seed": engine_seed(PAPER_X1, 1),  # clip 0 of this seed plays as paper_x1's clip 1
    "motion": {"level": "11_vs_11_stochastic", "capture_hz": 100, "frames": 150, "skip_s": 8.5},
    "sensors": [
        {
            "name": "mid100",
            "preset": "mid100-rose",
            "pose": {"x": 0.0, "y": -35.0, "z": 4.0, "pitch": -10.0, "yaw": 90.0},
        }
    ],
    "scan": {"frame_rate_hz": FRAME_RATE_HZ, "density": 8, "frames": 14},
}


@pytest.fixture(scope="module")
def restart():
    """The scenario, its captured clip, and its labelled frames."""
    from simgen.motion.engine import capture_motion

    scenario = parse_scenario(RESTART)
    clip = capture_motion(scenario.motion, scenario.seed)
    return scenario, clip, list(render_clip(scenario, clip, 0))


def test_interpolation_holds_each_side_of_a_placement():
    """A humanoid placed 30 m away at 0.45 s, between frames 0.4 and 0.5 s: before it, its pose of 0.4 s;
    from it on, its pose of 0.5 s; the other humanoid, not placed, moves linearly."""
    pose = np.zeros((12, 3), np.float32)
    clip = still_clip([pose, pose], ["left", "right"])
    keypoints = clip.keypoints_m.copy()
    keypoints[:, :, :, 0] += (np.arange(11) * 0.1)[:, None, None]  # both walk at 1 m/s along x
    keypoints[5:, 0, :, 0] += 30.0
    placed = np.full((11, 2), np.nan)
    placed[5, 0] = 0.45
    clip = type(clip)(**{**clip.__dict__, "keypoints_m": keypoints, "placed_s": placed})
    times = np.array([0.4, 0.43, 0.449, 0.45, 0.47, 0.5])
    keypoints, _ = interpolate_clip(clip, times)
    np.testing.assert_allclose(keypoints[:, 0, 0, 0], [0.4, 0.4, 0.4, 30.5, 30.5, 30.5], atol=1e-6)
    np.testing.assert_allclose(keypoints[:, 1, 0, 0], times, atol=1e-6)
    np.testing.assert_array_equal(segment_index(clip, times), [[0, 0]] * 3 + [[1, 0]] * 3)


@pytest.mark.engine
def test_capture_finds_the_restart_and_the_motion_file_keeps_it(restart, tmp_path):
    """One physics step holds every placement: exactly the humanoids whose centroid moves more than 0.3 m
    in those 10 ms (a sprint moves 0.11 m) are placed, at that step's time, and nowhere else."""
    _, clip, _ = restart
    centroid = clip.keypoints_m.mean(axis=2)
    jumped = np.linalg.norm(np.diff(centroid, axis=0), axis=-1) > 0.3  # (F - 1, H), 100 Hz: one physics step each
    placed = ~np.isnan(clip.placed_s)
    assert not placed[0].any()
    np.testing.assert_array_equal(placed[1:], jumped)
    frames = np.flatnonzero(placed.any(axis=1))
    assert len(frames) == 1 and placed[frames[0]].sum() >= 20
    assert np.all(clip.placed_s[placed] == clip.time_s[frames[0]]) and clip.time_s[frames[0]] == pytest.approx(9.13)
    again = read_clip(write_clip(clip, tmp_path / "motion.parquet"))
    np.testing.assert_array_equal(again.placed_s, clip.placed_s)
    np.testing.assert_array_equal(again.ball_placed_s, clip.ball_placed_s)
    np.testing.assert_array_equal(again.game_mode, clip.game_mode)


@pytest.mark.engine
def test_points_boxes_velocities_and_flags_around_the_restart(restart):
    """Every humanoid's point lies within 0.3 m of its box at the point's own time, the box built from the
    captured pose at or before that time (at 100 Hz, never more than 10 ms old); placed players are hit
    on both sides of the placement; velocities are finite and under 12 m/s; `discontinuity` is set on
    exactly the boxes whose humanoid was placed after the previous frame's label time and before the
    end of its sweep."""
    _, clip, frames = restart
    placed_at = float(np.nanmin(clip.placed_s))
    placed = ~np.isnan(clip.placed_s).all(axis=0)
    hits_before = hits_after = 0
    for frame in frames:
        scan, labels = frame.scan, frame.labels
        on_body = np.isin(scan.instance_id, clip.track_id)
        times = frame.time_s + scan.time_offset_s[on_body].astype(np.float64)
        captured = np.searchsorted(clip.time_s, times + 1e-9, side="right") - 1  # the pose at or before each point
        humanoid = np.searchsorted(clip.track_id, scan.instance_id[on_body])
        boxes = boxes_from_keypoints(clip.keypoints_m[captured, humanoid]).array
        points = scan.points_m[on_body]
        inside = np.array([in_box(p[None], b, 0.3)[0] for p, b in zip(points, boxes)], bool)
        assert inside.all(), (frame.index, points[~inside], times[~inside])
        hits_before += int((placed[humanoid] & (times < placed_at)).sum())
        hits_after += int((placed[humanoid] & (times >= placed_at)).sum())
        assert np.isfinite(labels.velocity_mps).all() and np.linalg.norm(labels.velocity_mps, axis=1).max() < 12.0
        # previous label time, sweep end
        since, until = frame.label_time_s - 1 / FRAME_RATE_HZ, frame.time_s + 1 / FRAME_RATE_HZ
        np.testing.assert_array_equal(labels.discontinuity, placed & (since < placed_at) & (placed_at <= until))
    assert hits_before > 0 and hits_after > 0
    flagged = [f.index for f in frames if f.labels.discontinuity.any()]
    assert 1 <= len(flagged) <= 2, flagged
    middle = KEYPOINT_INDEX["middle"]
    before, after = (
        np.searchsorted(clip.time_s, t) for t in (frames[flagged[0]].label_time_s - 1 / FRAME_RATE_HZ, placed_at)
    )
    assert (
        np.linalg.norm(
            clip.keypoints_m[after, placed, middle] - clip.keypoints_m[before, placed, middle], axis=-1
        ).max()
        > 5
    )


@pytest.mark.engine
def test_a_dataset_across_the_restart_verifies(tmp_path):
    """`simgen generate` then `simgen verify`: no player flies, no point is far from its box."""
    scenario = tmp_path / "restart.yaml"
    scenario.write_text(yaml.safe_dump(RESTART))
    result = run_simgen("generate", scenario, "-o", tmp_path / "data")
    assert result.returncode == 0, result.stderr
    result = run_simgen("verify", tmp_path / "data")
    assert result.returncode == 0 and " ok (" in result.stdout, result.stdout[-2000:]
