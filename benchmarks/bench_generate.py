"""End-to-end generation benchmark: `simgen generate` on the paper's x1 scenario against the per-frame
loop a user would write with the same libraries, and bytes per frame per format.

Frames per second count everything. Ours: `simgen generate` with 1 worker (engine capture at 100 Hz,
Mid-100 rendering with bodies posed per 10 ms slice, noise, intensity, labels, Parquet, manifest).
Baseline, in the same run, the same frames by a script run as its own process, start-up included as
ours is (`--loop-into DIR` runs it): per clip the same engine capture, then per
frame an Open3D RaycastingScene built from the ground, the static meshes and every body posed at
mid-frame (benchmarks/open3d_frame.py), the frame's rays cast on one thread, the hits' x, y, z and
the mesh each hit written as one Parquet file per frame. The baseline does less than ours (one pose
per frame, no noise, intensity, labels or manifest), so the ratio flatters it. 2 workers against 1
is a separate line (scaling, not a baseline). Bytes per frame are compared with the raw float32
(x, y, z, intensity) arrays of the same frames. Writes benchmarks/results/generate.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from open3d_frame import frozen_frame
from table import machine, markdown_table, write_results

from simgen.motion.engine import capture_motion
from simgen.pipeline.clip import engine_seed, frame_count
from simgen.scenario import Scenario, load_scenario, parse_scenario
from simgen.scene.static import build_static_scene

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "paper_x1.yaml"


def _generate(out: Path, *extra: str) -> float:
    command = [sys.executable, "-m", "simgen.cli", "generate", str(SCENARIO), "-o", str(out), *extra]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True)
    return time.perf_counter() - started


def _scenario(clips: int, frames: int) -> Scenario:
    """paper_x1 as `simgen generate --clips C --frames F` resolves it (motion captured just long enough)."""
    data = load_scenario(SCENARIO).model_dump()
    data["dataset"]["clips"] = clips
    data["scan"]["frames"] = frames
    data["motion"]["frames"] = int(frames / data["scan"]["frame_rate_hz"] * data["motion"]["capture_hz"] + 2)
    return parse_scenario(data, "benchmark")


def _per_frame_loop(scenario: Scenario, out: Path) -> None:
    """The user's loop: capture each clip, then cast and write each frame."""
    out.mkdir()
    static = build_static_scene(scenario.scene.goals, scenario.scene.surroundings, scenario.scene.net_transmission)
    for clip_index in range(scenario.dataset.clips):
        clip = capture_motion(scenario.motion, engine_seed(scenario, clip_index))
        for index in range(frame_count(scenario, clip)):
            scene, rays, tensor = frozen_frame(scenario, static, clip, index)
            hits = scene.cast_rays(tensor, nthreads=1)
            t_m = hits["t_hit"].numpy()
            kept = np.isfinite(t_m)
            xyz = (rays.origin_m[kept] + rays.direction[kept] * t_m[kept, None]).astype(np.float32)
            table = pa.table(
                {"x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2], "mesh": hits["geometry_ids"].numpy()[kept]}
            )
            pq.write_table(table, out / f"clip_{clip_index:04d}_frame_{index:06d}.parquet")


def _loop(out: Path, clips: int, frames: int) -> float:
    """Seconds for the user's loop as its own process (this script with --loop-into)."""
    command = [sys.executable, __file__, "--loop-into", str(out), "--clips", str(clips), "--frames", str(frames)]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True)
    return time.perf_counter() - started


def _totals(out: Path) -> tuple[int, int, int]:
    manifest = json.loads((out / "manifest.json").read_text())
    frames = sum(c["frames"] for c in manifest["clips"])
    points = sum(c["points"] for c in manifest["clips"])
    return frames, points, sum(f["bytes"] for f in manifest["files"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=4, help="clips (paper_x1 has 4)")
    parser.add_argument("--frames", type=int, default=205, help="frames per clip (paper_x1 has 205)")
    parser.add_argument("--loop-into", type=Path, help="run the baseline loop only, writing into this new folder")
    args = parser.parse_args()
    if args.loop_into:
        _per_frame_loop(_scenario(args.clips, args.frames), args.loop_into)
        return
    common = ["--clips", str(args.clips), "--frames", str(args.frames)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        loop_s = _loop(tmp / "loop", args.clips, args.frames)
        loop_frames = len(list((tmp / "loop").glob("*.parquet")))
        one_s = _generate(tmp / "one", *common)
        two_s = _generate(tmp / "two", *common, "--workers", "2")
        frames, points, parquet_bytes = _totals(tmp / "one")
        assert loop_frames == frames, (loop_frames, frames)
        rows = [
            ["per-frame loop: engine + Open3D + pyarrow, 1 process (baseline)", frames, f"{loop_s:.1f}",
             f"{frames / loop_s:.1f}", "1.00"],
            ["simgen generate, 1 worker", frames, f"{one_s:.1f}", f"{frames / one_s:.1f}", f"{loop_s / one_s:.2f}"],
        ]
        scaling = [
            ["simgen generate, 2 workers", frames, f"{two_s:.1f}", f"{frames / two_s:.1f}", f"{one_s / two_s:.2f}"]
        ]
        raw = points * 16 / frames  # float32 x, y, z, intensity
        sizes = [["raw float32 x, y, z, intensity (baseline)", f"{raw:,.0f}", "1.00"]]
        sizes.append(["parquet (all fields)", f"{parquet_bytes / frames:,.0f}", f"{parquet_bytes / frames / raw:.2f}"])
        for fmt in ("kitti", "kitti_tracking", "openpcdet"):
            _generate(tmp / fmt, "--clips", "1", "--frames", str(args.frames), "--format", fmt)
            f_frames, f_points, f_bytes = _totals(tmp / fmt)
            sizes.append([fmt, f"{f_bytes / f_frames:,.0f}", f"{f_bytes / f_frames / (f_points * 16 / f_frames):.2f}"])
    write_results(
        "generate",
        "Generation benchmark",
        f"`simgen generate scenarios/paper_x1.yaml --clips {args.clips} --frames {args.frames}` end to end "
        "(engine capture at 100 Hz, Mid-100 rendering with bodies posed per 10 ms slice, noise, intensity, labels, "
        "Parquet, manifest) against the loop a user would write with the same libraries for the same frames, run "
        "as its own process like ours (start-up counted for both): the same engine capture, then per frame an Open3D "
        "scene of the ground, static meshes and bodies posed at "
        "mid-frame, the frame's rays cast on one thread, x, y, z and the mesh hit written to one Parquet file per "
        "frame (less work than ours: one pose per frame, no noise, intensity, labels or manifest). "
        + machine(numpy=np.__version__),
        markdown_table(["run", "frames", "seconds", "frames/s", "ratio"], rows),
        "Scaling (not a baseline): the same command with 2 workers; ratio against 1 worker.",
        markdown_table(["run", "frames", "seconds", "frames/s", "ratio to 1 worker"], scaling),
        "Bytes per frame (paper_x1 frames; the KITTI-style formats from one clip):",
        markdown_table(["format", "bytes/frame", "ratio to raw"], sizes),
    )


if __name__ == "__main__":
    main()
