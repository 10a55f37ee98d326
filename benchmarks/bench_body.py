"""Humanoid meshes per second of simgen.body.mesh.body_meshes against building them with trimesh.

Each call poses H humanoids (random poses of simgen.motion.synthetic_poses spread over the pitch) and returns
their vertices, shared faces and per-face materials. Baseline, in the same run: the naive
per-pose build of the same 13 parts with `trimesh.creation.capsule` (similar vertex counts),
each moved onto its part by `apply_transform`. For scale, the floor: copying an array of the
same H x V x 3 float32 vertices.

Usage: .venv/bin/python benchmarks/bench_body.py [--out benchmarks/results/body.md]
"""

import argparse
import os
import platform
import time
import timeit
from collections.abc import Callable
from pathlib import Path

import numpy as np
import trimesh

from simgen.body import mesh as body
from simgen.motion.synthetic_poses import keypoints, random_pose
from simgen.vocab import TEAM_NAMES

HUMANOIDS = (1, 25, 100)
REPEATS = 5  # timing runs of at least 0.2 s each; the best counts


def trimesh_baseline(kp: np.ndarray) -> list[trimesh.Trimesh]:
    """One trimesh capsule per part, from end 0's cap centre to end 1's, mean radius of both."""
    centres = body._rig(kp)[:, :, :, 3]  # (H, P, 2, 3)
    radius = body._HALF_AXES_M[:, :, :2].mean(axis=(1, 2))
    meshes = []
    for ends in centres:
        for part, (start, end), r in zip(body._PARTS, ends, radius):
            axis = end - start
            transform = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis)
            transform[:3, 3] = start
            capsule = trimesh.creation.capsule(
                height=float(np.linalg.norm(axis)),
                radius=float(r),
                count=[part.segments, 2 * part.cap_rings + 2],
            )
            meshes.append(capsule.apply_transform(transform))
    return meshes


def seconds_per_call(fn: Callable[[], object]) -> float:
    """CPU seconds of this process per call: load from other processes does not count."""
    timer = timeit.Timer(fn, timer=time.process_time)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=REPEATS, number=number)) / number


def row(n: int, rng: np.random.Generator) -> str:
    """The table row for n humanoids in random poses over the pitch."""
    poses = [random_pose(rng) for _ in range(n)]
    kp = np.stack([keypoints(p, rng.uniform(-np.pi, np.pi), rng.uniform(-40, 40, 2)) for p in poses])
    teams = [TEAM_NAMES[i % len(TEAM_NAMES)] for i in range(n)]
    vertices = body.body_meshes(kp, teams).vertices_m
    ours = seconds_per_call(lambda: body.body_meshes(kp, teams))
    theirs = seconds_per_call(lambda: trimesh_baseline(kp))
    floor = seconds_per_call(vertices.copy)
    text = (
        f"| {n} | {ours * 1e6:,.0f} | {n / ours:,.0f} | {n / theirs:,.0f} | {theirs / ours:.0f}x "
        f"| {floor * 1e6:,.1f} |"
    )
    print(text, flush=True)
    return text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "body.md")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    rows = [row(n, rng) for n in HUMANOIDS]
    baseline_faces = sum(len(m.faces) for m in trimesh_baseline(np.stack([keypoints(random_pose(rng))])))
    header = [
        "# simgen.body.mesh benchmark",
        "",
        f"Written by `benchmarks/bench_body.py`; best of {REPEATS} timing runs, in CPU time of the "
        "process (`time.process_time`: on a shared machine, wall time runs higher). Python "
        f"{platform.python_version()}, numpy {np.__version__}, trimesh {trimesh.__version__}, "
        f"{platform.machine()} with {os.cpu_count()} CPUs at load {os.getloadavg()[0]:.1f}.",
        "",
        f"One call poses H humanoids of {body.NUM_VERTICES} vertices and {body.NUM_FACES} triangles "
        f"each ({len(body.PART_NAMES)} closed parts). Baseline: building the same parts per pose with "
        f"`trimesh.creation.capsule` and `apply_transform` ({baseline_faces} triangles a humanoid). "
        "Floor: copying the H x V x 3 float32 vertex array.",
        "",
        "| humanoids | us per call | meshes/s | trimesh meshes/s | speed-up | copy floor, us |",
        "| ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(header + rows) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
