"""Rendering benchmark: frames and rays per second of the Mid-100 and today's Livox sensors, beside a bare Embree cast.

- sensors, all on the default scenario's clip and scene: its Mid-100 (300 kHz) at x1 and x2; the four Mid-360
  of scenarios/modern_mid360.yaml (200 kHz each) replaying Livox's table and as the fitted rotors; one HAP
  (452 kHz, Livox's table) at the Mid-100's pose.
- ours: `simgen.pipeline.clip.render_clip` end to end (pattern shots, posing every body per 10 ms slice,
  casting, noise, labels), one process, one core; and two processes on the machine's two cores.
- baseline (same run): Open3D's RaycastingScene casting the same rays (one thread) against the
  same scene made static: a ground quad, the goals, and every body's mesh posed at the frame's
  middle; only the cast is timed (the scene is built beforehand).
Writes benchmarks/results/render.md.
"""

from __future__ import annotations

import argparse
import multiprocessing
import time
from pathlib import Path

import numpy as np
import open3d as o3d
from open3d_frame import frozen_frame
from table import machine, markdown_table, write_results

from simgen.motion.engine import capture_motion
from simgen.pipeline.clip import frame_count, render_clip
from simgen.scenario import load_scenario, parse_scenario
from simgen.scene.static import build_static_scene

ROOT = Path(__file__).resolve().parents[1]


def _scenario(density: float, frames: int, sensors: list[dict] | None = None):
    """The default scenario at `density`, cut to `frames`, with `sensors` (SensorConfig mappings) if given."""
    base = load_scenario(ROOT / "scenarios" / "default.yaml").model_dump()
    base["scan"] = {**base["scan"], "density": density, "frames": frames}
    if sensors is not None:
        base["sensors"] = sensors
    return parse_scenario(base)


def _rows(default) -> list[tuple[str, float, list[dict] | None]]:
    """(label, density, sensors) of each measured row; sensors None keeps the default scenario's Mid-100."""
    mid360 = [sensor.model_dump() for sensor in load_scenario(ROOT / "scenarios" / "modern_mid360.yaml").sensors]
    mid100 = default.sensors[0].model_dump()
    return [
        ("Mid-100 x1", 1.0, None),
        ("Mid-100 x2", 2.0, None),
        ("4 x Mid-360 (replay)", 1.0, [{**sensor, "preset": "mid360-replay"} for sensor in mid360]),
        ("4 x Mid-360 (rotors)", 1.0, [{**sensor, "preset": "mid360-rotors"} for sensor in mid360]),
        ("HAP (replay)", 1.0, [{**mid100, "name": "hap", "preset": "hap-replay"}]),
    ]


def _ours(scenario, clip, clip_index: int = 0) -> tuple[float, int]:
    """Seconds and rays to render the scenario's frames of the clip."""
    started = time.perf_counter()
    rays = sum(frame.scan.shots for frame in render_clip(scenario, clip, clip_index))
    return time.perf_counter() - started, rays


def _bare(scenario, clip, frames: int) -> tuple[float, int]:
    """Seconds and rays for Open3D to cast the same rays against the frozen scene."""
    static = build_static_scene(scenario.scene.goals, scenario.scene.surroundings, scenario.scene.net_transmission)
    seconds, rays_total = 0.0, 0
    for index in range(frames):
        scene, rays, tensor = frozen_frame(scenario, static, clip, index)
        scene.cast_rays(tensor, nthreads=1)  # builds the BVH: not timed
        started = time.perf_counter()
        scene.cast_rays(tensor, nthreads=1)
        seconds += time.perf_counter() - started
        rays_total += len(rays.time_s)
    return seconds, rays_total


def _clip_worker(args) -> tuple[int, float]:
    """Render one clip (the unit of work of `simgen generate`): its frame count and seconds."""
    scenario, clip, clip_index = args
    started = time.perf_counter()
    frames = sum(1 for _ in render_clip(scenario, clip, clip_index))
    return frames, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=0,
                        help="frames per measure (default: the default scenario's whole clip)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="measures of ours and of the bare cast; the best of each counts")
    args = parser.parse_args()
    default = load_scenario(ROOT / "scenarios" / "default.yaml")
    clip = capture_motion(default.motion, default.seed)
    whole = frame_count(default, clip)
    args.frames = args.frames or whole
    rows = []
    for label, density, sensors in _rows(default):
        _ours(_scenario(density, 3, sensors), clip)  # warm-up
        scenario = _scenario(density, args.frames, sensors)
        # Interleaved, best of `repeats` each: the two share whatever else the machine is doing.
        ours_s = bare_s = np.inf
        for _ in range(args.repeats):
            seconds, rays = _ours(scenario, clip)
            ours_s = min(ours_s, seconds)
            seconds, bare_rays = _bare(scenario, clip, args.frames)
            bare_s = min(bare_s, seconds)
        assert rays == bare_rays
        with multiprocessing.get_context("spawn").Pool(2) as pool:
            pool.map(_clip_worker, [(_scenario(density, 3, sensors), clip, 0)] * 2)  # start-up and warm-up
            results = pool.map(_clip_worker, [(scenario, clip, 0), (scenario, clip, 1)])
        done = sum(frames for frames, _ in results)
        both_s = max(seconds for _, seconds in results)
        fps = args.frames / ours_s
        rows.append([label, f"{rays / args.frames:,.0f}", f"{fps:.1f}", f"{rays / ours_s / 1e6:.2f}",
                     f"{bare_rays / bare_s / 1e6:.2f}", f"{(rays / ours_s) / (bare_rays / bare_s):.2f}",
                     f"{done / both_s:.1f}", f"{done / both_s / default.scan.frame_rate_hz:.1f}x"])
    write_results(
        "render",
        "Rendering benchmark",
        markdown_table(["sensor", "rays/frame", "frames/s, 1 core", "Mrays/s, ours", "Mrays/s, bare Open3D cast",
                        "ratio", "frames/s, 2 cores", "real time (10 Hz), 2 cores"], rows),
        f"{args.frames} frames of the default scenario{' (its whole clip)' if args.frames == whole else ''} per "
        f"measure, best of {args.repeats} interleaved measures of each (2 cores: two clips, one per process, once). "
        "The Mid-360 rows "
        "are the four masts of scenarios/modern_mid360.yaml (200 kHz each), the HAP (452 kHz) stands at the Mid-100's "
        "pose; every row renders the same clip and scene. Ours is end to end (shots, posing per 10 ms "
        "slice, casting, noise, labels); the bare cast is Open3D's RaycastingScene casting the same rays on one "
        "thread against the scene frozen at mid-frame (BVH built beforehand, not timed). Including the first "
        "cast (the BVH build) would add the scene build every frame, which the renderer never does. "
        + machine(numpy=np.__version__, open3d=o3d.__version__),
    )


if __name__ == "__main__":
    main()
