"""Measure the body's volume beyond its keypoints, and check that label boxes hold the mesh.

Usage: python scripts/measure_box_margins.py [--poses N] [--seed S] [--clip motion.parquet]

For the presets and N random poses of tests.support.poses (each at a random yaw), or for every
skeleton of a captured clip, per face of the label box, in metres:
- reach: how far the body mesh reaches beyond the keypoints (the margins a box drawn around
  the keypoints alone would need), largest and median over poses;
- slack: how far the box face lies beyond the mesh (simgen.labels.boxes sizes boxes from the body
  model, so this is >= 0 where the mesh is inside). The mesh counts from the ground up: what
  an engine pose puts below it is hidden by it.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this tree's packages, and tests.support's poses (a measurement, like benchmarks/)

from simgen.body.mesh import body_meshes
from simgen.labels.boxes import FACE_NAMES, boxes_from_keypoints, overhang
from simgen.motion.clip_io import read_clip
from tests.support.poses import PRESETS, keypoints, random_pose


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clip", type=Path, help="a motion clip (simgen capture) instead of random poses")
    args = parser.parse_args()
    if args.clip:
        kp = read_clip(args.clip).keypoints_m.reshape(-1, 12, 3).astype(np.float64)
    else:
        rng = np.random.default_rng(args.seed)
        poses = list(PRESETS.values()) + [random_pose(rng) for _ in range(args.poses)]
        kp = np.stack([keypoints(pose, yaw_rad=rng.uniform(-np.pi, np.pi)) for pose in poses])
    boxes = boxes_from_keypoints(kp)
    vertices = body_meshes(kp, ["left"] * len(kp)).vertices_m
    vertices[..., 2] = np.maximum(vertices[..., 2], 0.0)
    mesh = overhang(vertices, boxes)
    reach = mesh - overhang(kp, boxes)
    print(f"{len(kp):6d} poses reach max  reach p50   slack min  slack max")
    for i, face in enumerate(FACE_NAMES):
        print(
            f"{face:8s} {reach[:, i].max():10.3f} {np.median(reach[:, i]):10.3f}"
            f" {-mesh[:, i].max():11.3f} {-mesh[:, i].min():10.3f}"
        )


if __name__ == "__main__":
    main()
