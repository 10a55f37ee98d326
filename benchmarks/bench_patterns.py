"""Shots generated per second by each scan pattern, against plain numpy computing the same shots.

Each case generates one window of shots (times and head-frame unit directions, as the renderer
gets them) with `scan_patterns.head_shots`, or a whole sensor's frame with `frame_shots`. The
baseline, measured in the same run, is what a user would write from the pattern's formula with
numpy alone, for the same shots: the shot times on the head's clock, then
- risley: the prism angles theta_i = 2 pi rpm_i / 60 t + phase_i and Snell's law in vector form
  at the four prism faces, as arrays over all shots;
- rose: rho = A sin(k theta + theta0), theta and theta0 turning uniformly, as off-axis unit vectors;
- replay: the file's directions (loaded once, outside the timing) interpolated at the shot times
  with `np.interp`, one axis at a time, and normalised;
- Mid-100: the Risley baseline per head at its time offset, turned by its yaw, heads concatenated.
Ratio = our shots/s / numpy's; the largest angle between our directions and numpy's (same times)
shows both compute the same shots.

Usage: .venv/bin/python benchmarks/bench_patterns.py [--out benchmarks/results/patterns.md]
"""

import argparse
import math
import timeit
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from table import machine, markdown_table, row, write_results

import scan_patterns as sp
from scan_patterns.replay import load_pattern_file
from scan_patterns.shots import angle_between_deg

REPEATS = 5  # timing runs of at least 0.2 s each; the best counts
WINDOW_S = 1.0  # 100,000 shots per head at x1
TARGET_RISLEY_SHOTS_PER_S = 20e6
Directions = tuple[np.ndarray, np.ndarray]  # shot times (N,) s, unit directions (N, 3) float32


def seconds_per_call(fn: Callable[[], object]) -> float:
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=REPEATS, number=number)) / number


def clock_times(t0_s: float, t1_s: float, rate_hz: float) -> np.ndarray:
    """Shot k fires at k / rate; the window (t0, t1] holds the shots after t0 up to t1."""
    return np.arange(math.floor(t0_s * rate_hz + 1e-6) + 1, math.floor(t1_s * rate_hz + 1e-6) + 1) / rate_hz


def refract(s, normal, eta):
    """Snell's law in vector form for arrays of directions s (x, y, z) through faces `normal`, eta = n1 / n2."""
    cos_in = s[0] * normal[0] + s[1] * normal[1] + s[2] * normal[2]
    k = np.sqrt(1.0 - eta**2 * (1.0 - cos_in**2)) - eta * cos_in
    return tuple(eta * si + k * ni for si, ni in zip(s, normal, strict=True))


def numpy_risley(head: sp.HeadSpec, t0_s: float, t1_s: float, density: float = 1.0) -> Directions:
    """A Mid-40 Risley head's shots from the prisms' angles and Snell's law at their four faces."""
    p = head.model
    t = clock_times(t0_s + head.time_offset_s, t1_s + head.time_offset_s, head.shots_per_s * density)
    theta = [2 * np.pi * rpm / 60.0 * t + np.radians(phase) for rpm, phase in zip(p.rpm, p.phase_deg, strict=True)]
    wedge = [np.radians(w) for w in p.wedge_deg]
    ones, zeros = np.ones_like(t), np.zeros_like(t)
    s = (ones, zeros, zeros)  # into prism 1 through its flat face, normal incidence: no turn
    for i, eta in ((0, p.index), (1, 1.0 / p.index)):  # out of prism 1's wedged face, into prism 2's
        s = refract(
            s, (np.cos(wedge[i]), np.sin(wedge[i]) * np.cos(theta[i]), np.sin(wedge[i]) * np.sin(theta[i])), eta
        )
    s = refract(s, (ones, zeros, zeros), p.index)  # out of prism 2's flat face
    return t - head.time_offset_s, np.stack(s, axis=1).astype(np.float32)


def numpy_rose(head: sp.HeadSpec, t0_s: float, t1_s: float) -> Directions:
    """The rose rho = A sin(k theta + theta0) at the shot times, as off-axis unit vectors."""
    p = head.model
    t = clock_times(t0_s, t1_s, head.shots_per_s)
    theta = 2 * np.pi * p.petals_per_s / (2 * p.k) * t
    rho = np.radians(head.fov_deg / 2) * np.sin(2 * np.pi * (p.petals_per_s / 2 + p.theta0_hz) * t)
    dirs = np.stack([np.cos(rho), np.sin(rho) * np.cos(theta), np.sin(rho) * np.sin(theta)], axis=1)
    return t, dirs.astype(np.float32)


def numpy_replay(file_t_s: np.ndarray, file_dirs: np.ndarray, t0_s: float, t1_s: float, rate_hz: float) -> Directions:
    """A pattern file's directions interpolated at the shot times (linear per axis), normalised."""
    t = clock_times(t0_s, t1_s, rate_hz)
    dirs = np.stack([np.interp(t, file_t_s, file_dirs[:, axis]) for axis in range(3)], axis=1)
    return t, (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)


def numpy_mid100(sensor: sp.SensorSpec, t0_s: float, t1_s: float, density: float) -> Directions:
    """Each head's Risley shots turned by its yaw, heads one after another."""
    parts = []
    for head in sensor.heads:
        t, dirs = numpy_risley(head, t0_s, t1_s, density)
        yaw = np.radians(head.yaw_deg)
        turn = np.array(
            [[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]], np.float32
        )
        parts.append((t, dirs @ turn.T))
    return np.concatenate([t for t, _ in parts]), np.concatenate([d for _, d in parts])


def cases() -> list[tuple[str, str, Callable[[], sp.Shots], Callable[[], Directions]]]:
    head = {name: sp.get_sensor(name).heads[0] for name in ("mid40-risley", "mid40-rose", "mid40-replay")}
    mid100 = sp.get_sensor("mid100-risley")
    replay = load_pattern_file(head["mid40-replay"].model)
    replay_dirs = replay.dirs.astype(np.float64)
    rate = head["mid40-replay"].shots_per_s
    return [
        ("risley", "Mid-40 head, 1 s at x1", lambda: sp.head_shots(head["mid40-risley"], 10.0, 10.0 + WINDOW_S),
         lambda: numpy_risley(head["mid40-risley"], 10.0, 10.0 + WINDOW_S)),
        ("risley", "Mid-40 head, 1 s at x4", lambda: sp.head_shots(head["mid40-risley"], 10.0, 10.0 + WINDOW_S, 4.0),
         lambda: numpy_risley(head["mid40-risley"], 10.0, 10.0 + WINDOW_S, 4.0)),
        ("rose", "Mid-40 head, 1 s at x1", lambda: sp.head_shots(head["mid40-rose"], 10.0, 10.0 + WINDOW_S),
         lambda: numpy_rose(head["mid40-rose"], 10.0, 10.0 + WINDOW_S)),
        ("replay", "Mid-40 file, 1 s at x1", lambda: sp.head_shots(head["mid40-replay"], 1.0, 1.0 + WINDOW_S),
         lambda: numpy_replay(replay.t_s, replay_dirs, 1.0, 1.0 + WINDOW_S, rate)),
        ("replay", "Mid-40 file, 1 s at x2", lambda: sp.head_shots(head["mid40-replay"], 1.0, 1.0 + WINDOW_S, 2.0),
         lambda: numpy_replay(replay.t_s, replay_dirs, 1.0, 1.0 + WINDOW_S, 2 * rate)),
        ("mid100-risley", "10 Hz frame at x2, 3 heads yawed", lambda: sp.frame_shots(mid100, 100, 10.0, 2.0),
         lambda: numpy_mid100(mid100, 10.0, 10.1, 2.0)),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/patterns.md)")
    args = parser.parse_args()
    warnings.simplefilter("error", sp.PatternLoopWarning)  # the windows stay inside the file
    rows = []
    risley_rates = []
    for pattern, case, generate, baseline in cases():
        shots, (t, dirs) = generate(), baseline()
        n = len(shots)
        assert len(t) == n and np.allclose(t, shots.t_s, rtol=0, atol=1e-9), (case, len(t), n)
        differs_deg = float(angle_between_deg(shots.dirs, dirs).max())
        theirs = seconds_per_call(baseline)
        mine = seconds_per_call(generate)
        if pattern == "risley":
            risley_rates.append(n / mine)
        rows.append([pattern, case, f"{n:,}", f"{mine * 1e3:.2f}", f"{n / mine / 1e6:.1f}", f"{n / theirs / 1e6:.1f}",
                     f"{differs_deg:.1e}", f"{theirs / mine:.2f}"])
        print(row(rows[-1]), flush=True)
    verdict = "met" if min(risley_rates) >= TARGET_RISLEY_SHOTS_PER_S else "NOT met"
    write_results(
        "patterns",
        "scan_patterns benchmark",
        f"Written by `benchmarks/bench_patterns.py`; best of {REPEATS} timing runs. " + machine(numpy=np.__version__),
        "A shot is its time (float64) and head-frame unit direction (float32), as the renderer gets "
        "them. Baseline, in the same run: the same shots from the pattern's formula in plain numpy (Risley: "
        "prism angles and Snell's law at the four faces; rose: rho = A sin(k theta + theta0); replay: the "
        "file's directions by `np.interp` at the shot times, normalised; Mid-100: the Risley baseline per "
        "head, turned by its yaw). Ratio = our shots/s / numpy's; *differs* is the largest angle between "
        "our direction and numpy's for the same shot.\n"
        f"Target for `risley`: at least {TARGET_RISLEY_SHOTS_PER_S / 1e6:.0f} M shots/s ({verdict}).",
        markdown_table(["pattern", "case", "shots", "ms per call", "M shots/s", "M shots/s numpy (baseline)",
                        "differs, deg", "ratio"], rows, left=2),
        out=args.out,
    )


if __name__ == "__main__":
    main()
