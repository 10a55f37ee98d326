"""Streaming benchmark: peak memory against frames per clip, where a frame's time goes, and a whole
match's projected wall time, on `scenarios/full_match.yaml` (one Mid-100 x1, one clip).

1. Peak RSS of `simgen generate --clips 1 --frames N --workers 1` (one process: capture, rendering
   and writing all in it) for each N; baseline: the smallest N, same run. Frames are streamed to
   disk, so the ratio should stay near 1 (the issue's target: within 20 %).
2. For the largest N, frames per second of one core: end to end (`simgen generate`, 1 worker),
   engine capture only (`capture_motion` of the motion those frames need) and rendering only
   (`render_frames`, labels included, nothing written), same frames, same run. End to end minus
   the two is what writing, hashing and the manifest cost.
3. A whole match (54,000 frames) projected on this machine with W workers: the capture is one
   engine playing in order (capture time x 54,000 / N); the rest is split over the workers' shards.
4. A shard's motion at a whole match's length: the largest N's capture repeated to 54,000 frames,
   stored as `simgen generate` keeps it between capture and shards (arrays that a shard maps,
   `read_clip_arrays`), against the same clip as a Parquet motion file read whole (`read_clip`, as
   `simgen capture` writes it); a child process opens it and poses the last shard's 3,000 frames.
   Peak RSS over a child that only imports the same modules and poses 50 frames (compiling the kernels).
Writes benchmarks/results/stream.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from simgen.pipeline.jobs import AUTO_SHARD_MAX_FRAMES

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "full_match.yaml"
MATCH_FRAMES = 54_000


def _measured(command: list[str], report: Path) -> dict:
    """Run `command` under measure_child.py (which keeps this process's RSS out of the child's peak);
    its usage: exit_code, peak_bytes, cpu_s, minor_faults."""
    launcher = [sys.executable, str(ROOT / "benchmarks" / "measure_child.py"), str(report)]
    subprocess.run([*launcher, *command], cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return json.loads(report.read_text())


def _generate(out: Path, frames: int, shard_frames: int = 0) -> tuple[float, float, int]:
    """Wall seconds, peak RSS (MiB) and minor page faults of one `simgen generate` process."""
    command = [
        sys.executable,
        "-m",
        "simgen.cli",
        "generate",
        str(SCENARIO),
        "-o",
        str(out),
        "--clips",
        "1",
        "--frames",
        str(frames),
    ]
    command += ["--shard-frames", str(shard_frames)] if shard_frames else []
    started = time.perf_counter()
    usage = _measured(command, out.parent / f"usage-{frames}-{shard_frames}")
    seconds = time.perf_counter() - started
    if usage["exit_code"] != 0:
        raise SystemExit(f"simgen generate --frames {frames} failed")
    return seconds, usage["peak_bytes"] / 2**20, usage["minor_faults"]


SHARD_POSES = """
import sys
import numpy as np
from simgen.labels.boxes import label_poses
from simgen.motion.clip_io import read_clip, read_clip_arrays
warm = read_clip_arrays(sys.argv[3])  # compiles the labels' kernels: every child pays for that
label_poses(warm, warm.time_s[0] + (np.arange(50) + 0.5) / 10)
del warm
if sys.argv[1] != "imports":
    clip = (read_clip if sys.argv[1] == "parquet" else read_clip_arrays)(sys.argv[2])
    times = clip.time_s[0] + (np.arange(MATCH - 3000, MATCH) + 0.5) / 10
    for first in range(0, len(times), 50):
        label_poses(clip, times[first : first + 50])
""".replace("MATCH", str(MATCH_FRAMES))


def _match_motion(clip, directory: Path) -> dict[str, float]:
    """Peak RSS (MiB) of a child posing a whole match's last 3,000 frames: "imports" (and 50 frames) only, the
    motion "parquet" read whole, or its "arrays" mapped."""
    from simgen.motion.clip_io import write_clip, write_clip_arrays

    repeats = -(-MATCH_FRAMES * clip.capture_hz // (10 * clip.num_frames)) + 1  # 10 Hz frames
    frames = repeats * clip.num_frames
    match = dataclasses.replace(
        clip,
        time_s=clip.time_s[0] + np.arange(frames) / clip.capture_hz,
        keypoints_m=np.tile(clip.keypoints_m, (repeats, 1, 1, 1)),
        ball_m=np.tile(clip.ball_m, (repeats, 1)),
        engine_position_m=np.tile(clip.engine_position_m, (repeats, 1, 1)),
    )
    paths = {
        "imports": "",
        "parquet": write_clip(match, directory / "match.parquet"),
        "arrays": write_clip_arrays(match, directory / "match"),
    }
    peaks = {}
    for mode, path in paths.items():
        usage = _measured(
            [sys.executable, "-c", SHARD_POSES, mode, str(path), str(paths["arrays"])], directory / f"usage-{mode}"
        )
        if usage["exit_code"] != 0:
            raise SystemExit(f"posing the match's motion ({mode}) failed")
        peaks[mode] = usage["peak_bytes"] / 2**20
    return peaks


def _capture_and_render(frames: int):
    """Seconds to capture the motion of `frames` frames, and to render them (labels included), the
    minor page faults of rendering, and the motion."""
    from simgen.motion.engine import capture_motion
    from simgen.pipeline.clip import engine_seed, label_sizes, render_frames
    from simgen.scenario import load_scenario, parse_scenario

    data = load_scenario(SCENARIO).model_dump()
    data["scan"]["frames"] = frames
    data["motion"]["frames"] = int(frames / data["scan"]["frame_rate_hz"] * data["motion"]["capture_hz"] + 2)
    scenario = parse_scenario(data)
    started = time.perf_counter()
    clip = capture_motion(scenario.motion, engine_seed(scenario, 0))
    capture_s = time.perf_counter() - started
    started, faults = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in render_frames(scenario, clip, 0, 0, frames, label_sizes(scenario, clip)):
        pass
    return capture_s, time.perf_counter() - started, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults, clip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--frames", default="100,1000,6000", help="frames per clip, comma-separated (default 100,1000,6000)"
    )
    parser.add_argument("--workers", type=int, default=2, help="workers of the projected whole-match run (default 2)")
    args = parser.parse_args()
    sizes = sorted(int(n) for n in args.frames.split(","))
    _capture_and_render(3)  # compile the numba kernels once, outside every measure
    with tempfile.TemporaryDirectory() as tmp:
        runs = {n: _generate(Path(tmp) / f"f{n}", n) for n in sizes}
        # the largest N is rendered in shards (automatic: at most AUTO_SHARD_MAX_FRAMES each) and joined: the
        # smallest N sharded in two, the same code path, is its like-for-like baseline
        sharded_base = _generate(Path(tmp) / "sharded", sizes[0], max(sizes[0] // 2, 1))
    largest = sizes[-1]
    capture_s, render_s, render_faults, clip = _capture_and_render(largest)
    with tempfile.TemporaryDirectory() as tmp:
        motion = _match_motion(clip, Path(tmp))
    held = {mode: motion[mode] - motion["imports"] for mode in ("parquet", "arrays")}
    e2e_s, base_rss = runs[largest][0], runs[sizes[0]][1]
    rss_rows = [f"| {n:,} | {rss:,.0f} | {rss / base_rss:.2f} |" for n, (_, rss, _) in runs.items()]
    # faults a frame adds end to end: the largest run's over the smallest's, per extra frame
    e2e_faults = (runs[largest][2] - runs[sizes[0]][2]) / max(largest - sizes[0], 1)
    rest_s = max(e2e_s - capture_s, 0.0)
    scale = MATCH_FRAMES / largest
    match_s = capture_s * scale + rest_s * scale / args.workers
    rate_rows = [
        f"| end to end (`simgen generate`, 1 worker) | {largest / e2e_s:.1f} | 1.00 |",
        f"| engine capture only | {largest / capture_s:.1f} | {e2e_s / capture_s:.2f} |",
        f"| rendering + labels only | {largest / render_s:.1f} | {e2e_s / render_s:.2f} |",
        "| writing, hashing, manifest (end to end - capture - rendering) | "
        f"{largest / max(e2e_s - capture_s - render_s, 1e-9):.1f} | "
        f"{e2e_s / max(e2e_s - capture_s - render_s, 1e-9):.2f} |",
    ]
    text = (
        "# Streaming benchmark\n\n"
        f"`simgen generate scenarios/full_match.yaml --clips 1 --frames N --workers 1` on this machine "
        f"({os.cpu_count()} cores, shared).\n\n"
        "Peak RSS of the one process (capture, rendering, writing), against the smallest N of the same run:\n\n"
        "| frames per clip | peak RSS, MiB | ratio |\n|---|---|---|\n" + "\n".join(rss_rows) + "\n\n"
        f"Shards: {largest:,} frames are rendered as {-(-largest // AUTO_SHARD_MAX_FRAMES)} shards and joined (reading "
        f"the partial clips "
        f"back); {sizes[0]:,} frames in two shards of {max(sizes[0] // 2, 1):,} take that path too: peak "
        f"{sharded_base[1]:,.0f} MiB, "
        f"so {largest:,} frames are {runs[largest][1] / sharded_base[1]:.2f}x the same path at {sizes[0]:,} frames.\n\n"
        f"Where {largest:,} frames' time goes, frames/s of one core (ratio: end to end seconds / the part's "
        f"seconds):\n\n"
        "| part | frames/s | ratio |\n|---|---|---|\n" + "\n".join(rate_rows) + "\n\n"
        f"Minor page faults per frame: {e2e_faults:.1f} end to end (the {largest:,}-frame run's over the "
        f"{sizes[0]:,}-frame run's, "
        f"per extra frame), {render_faults / largest:.1f} in rendering + labels alone (first frame included).\n\n"
        f"Whole match ({MATCH_FRAMES:,} frames) projected from the {largest:,}-frame run with {args.workers} workers: "
        f"capture {capture_s * scale / 3600:.2f} h (one engine, in order) "
        f"+ the rest {rest_s * scale / args.workers / 3600:.2f} h "
        f"(shards over {args.workers} workers) = {match_s / 3600:.2f} h.\n\n"
        f"A shard's motion at a whole match's length ({clip.keypoints_m.nbytes * MATCH_FRAMES / largest / 2**20:,.0f} "
        f"MiB of keypoints; the "
        f"last 3,000 frames posed in a child process), peak RSS over a child that only imports and poses 50 frames "
        f"({motion['imports']:,.0f} MiB):\n\n"
        "| motion | peak RSS over imports, MiB | ratio |\n|---|---|---|\n"
        f"| Parquet motion file read whole (`read_clip`) | {held['parquet']:,.0f} | 1.00 |\n"
        f"| run-state arrays, mapped (`read_clip_arrays`, what `simgen generate` uses) | {held['arrays']:,.0f} | "
        f"{held['arrays'] / held['parquet']:.2f} |\n"
    )
    print(text)
    (ROOT / "benchmarks" / "results" / "stream.md").write_text(text)


if __name__ == "__main__":
    main()
