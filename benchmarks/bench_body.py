"""Humanoid meshes per second of simgen.body.mesh.body_meshes against trimesh posing the same meshes.

Each call poses H humanoids (random poses of tests.support.poses spread over the pitch) and
returns their vertices, shared faces and per-face materials. Baseline, in the same run, the way a
trimesh user poses prebuilt meshes: the same part meshes (`part_templates`) and each humanoid's joined
faces kept once, then per call every part's vertices moved by `trimesh.transformations.transform_points`
with its rigid frame (`part_frames`, as ours computes them) and each humanoid built as a
`trimesh.Trimesh`. (Copying per-part `Trimesh` objects, `apply_transform` and
`trimesh.util.concatenate` was slower still: 6x in a trial.) Both give the same vertices (checked). For scale,
the floor: copying an array of the same H x V x 3 float32 vertices.

In the renderer `body_meshes` runs once per clip (`part_templates`); per frame only `part_frames`
moves the parts, timed here too.

Usage: .venv/bin/python benchmarks/bench_body.py [--out benchmarks/results/body.md]
"""

import argparse
import sys
import time
import timeit
from collections.abc import Callable
from pathlib import Path

import numpy as np
import trimesh
from table import machine, markdown_table, row, write_results
from trimesh.transformations import transform_points

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this tree's packages, and tests.support's poses

from simgen.body import mesh as body
from simgen.vocab import TEAM_NAMES
from tests.support.poses import keypoints, random_pose

HUMANOIDS = (1, 25, 100)
REPEATS = 5  # timing runs of at least 0.2 s each; the best counts


def trimesh_templates(kp: np.ndarray, teams: list[str]) -> list[tuple[list[np.ndarray], np.ndarray]]:
    """Per humanoid: its parts' vertices in part coordinates and the joined faces (built once)."""
    parts = body.part_templates(kp, teams)
    starts = np.cumsum([0] + [len(vertices[0]) for vertices, _, _ in parts])
    faces = np.concatenate([part_faces + start for (_, part_faces, _), start in zip(parts, starts)])
    return [([vertices[h] for vertices, _, _ in parts], faces) for h in range(len(kp))]


def trimesh_pose(templates: list[tuple[list[np.ndarray], np.ndarray]], kp: np.ndarray) -> list[trimesh.Trimesh]:
    """One Trimesh per humanoid: every part's vertices moved onto its frame by trimesh, then joined."""
    rotation, origin = body.part_frames(kp)
    transform = np.zeros(rotation.shape[:2] + (4, 4))
    transform[..., :3, :3], transform[..., :3, 3], transform[..., 3, 3] = rotation, origin, 1.0
    return [
        trimesh.Trimesh(
            np.concatenate([transform_points(v, t) for v, t in zip(parts, transforms)]), faces, process=False
        )
        for (parts, faces), transforms in zip(templates, transform)
    ]


def seconds_per_call(fn: Callable[[], object]) -> float:
    """CPU seconds of this process per call: load from other processes does not count."""
    timer = timeit.Timer(fn, timer=time.process_time)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat=REPEATS, number=number)) / number


def measure(n: int, rng: np.random.Generator) -> list[str]:
    """The table row for n humanoids in random poses over the pitch."""
    poses = [random_pose(rng) for _ in range(n)]
    kp = np.stack([keypoints(p, rng.uniform(-np.pi, np.pi), rng.uniform(-40, 40, 2)) for p in poses])
    teams = [TEAM_NAMES[i % len(TEAM_NAMES)] for i in range(n)]
    vertices = body.body_meshes(kp, teams).vertices_m
    templates = trimesh_templates(kp, teams)
    theirs_vertices = np.stack([m.vertices for m in trimesh_pose(templates, kp)])
    np.testing.assert_allclose(theirs_vertices, vertices, atol=1e-5)  # the same meshes
    ours = seconds_per_call(lambda: body.body_meshes(kp, teams))
    theirs = seconds_per_call(lambda: trimesh_pose(templates, kp))
    frames = seconds_per_call(lambda: body.part_frames(kp))
    floor = seconds_per_call(vertices.copy)
    cells = [n, f"{ours * 1e6:,.0f}", f"{n / ours:,.0f}", f"{n / theirs:,.0f}", f"{theirs / ours:.1f}x",
             f"{frames * 1e6:,.1f}", f"{floor * 1e6:,.1f}"]
    print(row(cells), flush=True)
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="results file (default: benchmarks/results/body.md)")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    rows = [measure(n, rng) for n in HUMANOIDS]
    write_results(
        "body",
        "simgen.body.mesh benchmark",
        f"Written by `benchmarks/bench_body.py`; best of {REPEATS} timing runs, in CPU time of the process "
        "(`time.process_time`: on a shared machine, wall time runs higher). "
        + machine(numpy=np.__version__, trimesh=trimesh.__version__),
        f"One call poses H humanoids of {body.NUM_VERTICES} vertices and {body.NUM_FACES} triangles each "
        f"({len(body.PART_NAMES)} closed parts). Baseline: trimesh posing the same part meshes, prebuilt once: per "
        "call `trimesh.transformations.transform_points` of every part's vertices with its frame, and a `Trimesh` "
        "per humanoid (the same vertices as ours). `part_frames`: the per-frame cost "
        "in the renderer, which builds the meshes once per clip and then moves only the parts' frames. Floor: "
        "copying the H x V x 3 float32 vertex array.",
        markdown_table(
            [
                "humanoids",
                "us per call",
                "meshes/s",
                "trimesh meshes/s",
                "speed-up",
                "part_frames, us",
                "copy floor, us",
            ],
            rows,
            left=0,
        ),
        out=args.out,
    )


if __name__ == "__main__":
    main()
