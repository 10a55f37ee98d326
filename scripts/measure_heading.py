"""How the label heading (the shoulders' perpendicular) moves from frame to frame, and why.

Captures one clip of a scenario from the real engine at its `capture_hz` (paper_x1: 100 Hz), takes every
player's heading at every captured frame (simgen.body.heading), and reports:

- its change over one scan frame (1 / scan.frame_rate_hz), the label's frame-to-frame change;
- the same for the heading averaged over 0.5 s, and the residual about that average: its size and the
  frequencies it holds (mean power spectrum over the players);
- the twist of the shoulder line against the hip line;
- the change by speed (standing, walking, running);
- its smoothness: the heading's second difference per capture step (noise would show up there).

Usage: .venv/bin/python scripts/measure_heading.py [scenarios/paper_x1.yaml] [--clip 3]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from simgen.body.heading import heading, wrap_angle
from simgen.motion.engine import capture_motion
from simgen.pipeline.clip import engine_seed
from simgen.scenario import load_scenario
from simgen.vocab import KEYPOINT_INDEX

WINDOW_S = 0.5  # the averaging window that separates turning from the stride's twist


def _line_yaw(keypoints: np.ndarray, left: str, right: str) -> np.ndarray:
    """Yaw (rad) of the perpendicular of a left-right line, as simgen.body.heading takes the shoulders'."""
    d = keypoints[..., KEYPOINT_INDEX[left], :2] - keypoints[..., KEYPOINT_INDEX[right], :2]
    return np.arctan2(-d[..., 0], d[..., 1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=str(ROOT / "scenarios" / "paper_x1.yaml"))
    parser.add_argument("--clip", type=int, default=3, help="clip index (default: 3, paper_x1's val clip)")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    clip = capture_motion(scenario.motion, engine_seed(scenario, args.clip))
    players = np.flatnonzero(clip.team != "official")
    kp = clip.keypoints_m.astype(np.float64)[:, players]
    frames, count = kp.shape[:2]
    step_s = 1.0 / clip.capture_hz
    yaw = heading(kp.reshape(-1, 12, 3)).yaw_rad.reshape(frames, count)
    scan = max(1, round(clip.capture_hz / scenario.scan.frame_rate_hz))
    change = np.degrees(np.abs(wrap_angle(yaw[scan:] - yaw[:-scan])))
    unwrapped = np.unwrap(yaw, axis=0)
    width = max(3, round(WINDOW_S / step_s) | 1)
    smooth = np.stack([np.convolve(unwrapped[:, i], np.ones(width) / width, mode="same") for i in range(count)], 1)
    inner = slice(width, frames - width)
    residual = np.degrees(wrap_angle(unwrapped - smooth))[inner]
    smooth_change = np.degrees(np.abs(wrap_angle(smooth[scan:] - smooth[:-scan])))[width:-width]
    spectrum = np.mean(np.abs(np.fft.rfft(residual - residual.mean(0), axis=0)) ** 2, axis=1)
    frequencies = np.fft.rfftfreq(len(residual), d=step_s)
    twist = np.degrees(wrap_angle(yaw - _line_yaw(kp, "left_thigh", "right_thigh")))
    middle = kp[:, :, KEYPOINT_INDEX["middle"], :2]
    speed = np.linalg.norm(np.gradient(middle, clip.time_s, axis=0), axis=-1)[scan:]
    second = np.degrees(np.abs(wrap_angle(unwrapped[2:] - 2 * unwrapped[1:-1] + unwrapped[:-2])))

    def pct(values: np.ndarray) -> str:
        return "median {:.1f}, p90 {:.1f}, p99 {:.1f}".format(*np.percentile(values, [50, 90, 99]))

    print(
        f"{scenario.name} clip {args.clip}: {count} players, {frames} frames at {clip.capture_hz} Hz; one scan frame = "
        f"{scan} steps"
    )
    print(f"heading change per scan frame, degrees: {pct(change)}")
    print(f"the {WINDOW_S:g} s average's change per scan frame: {pct(smooth_change)}")
    print(
        f"residual about the {WINDOW_S:g} s average: rms {np.sqrt(np.mean(residual**2)):.1f} degrees; "
        f"strongest frequencies {', '.join(f'{f:.2f}' for f in frequencies[np.argsort(spectrum[1:])[::-1][:3] + 1])} Hz"
    )
    print(f"shoulders against hips: rms twist {np.sqrt(np.mean(twist ** 2)):.1f} degrees")
    for low, high in ((0.0, 0.5), (0.5, 2.0), (2.0, 4.0), (4.0, 20.0)):
        chosen = (speed >= low) & (speed < high)
        print(f"  at {low:g}-{high:g} m/s ({chosen.mean():.0%} of samples): change per scan frame median "
              f"{np.median(change[chosen]):.1f}, p90 {np.percentile(change[chosen], 90):.1f} degrees")
    print(
        f"second difference per capture step, degrees: median {np.median(second):.3f}, "
        f"p99 {np.percentile(second, 99):.2f}"
    )


if __name__ == "__main__":
    main()
