"""Which Embree binding to cast with: Open3D's RaycastingScene vs embreex (what trimesh's Embree
intersector uses), on the renderer's own workloads.

Workloads, on the default scenario's first frame: (a) all 30,000 Mid-100 rays against the scene
frozen as meshes (ground quad, goals, 25 bodies); (b) the small batches the renderer really casts
per frame: ~3,000 rays moved into body-part frames against the part templates. Build time (once per
clip in the renderer) and cast time are reported separately; the baseline is Open3D.
Writes benchmarks/results/raycasters.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import open3d as o3d
from embreex import mesh_construction, rtcore_scene
from table import machine, markdown_table, write_results

from simgen.body.mesh import body_meshes
from simgen.motion.engine import capture_motion
from simgen.motion.interpolate import interpolate_clip
from simgen.scan.sensor import scenario_sensors
from simgen.scan.sensor_rig import frame_rays
from simgen.scenario import load_scenario
from simgen.scene.static import build_static_scene

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 20


def _best(function) -> float:
    times = []
    for _ in range(REPEATS):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return min(times)


def _open3d(vertices, faces, origins, directions):
    def build():
        scene = o3d.t.geometry.RaycastingScene(nthreads=1)
        scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces.astype(np.uint32)))
        scene.cast_rays(o3d.core.Tensor(np.zeros((1, 6), np.float32)), nthreads=1)  # BVH is built lazily
        return scene

    scene = build()
    rays = np.concatenate([origins, directions], axis=1).astype(np.float32)
    def cast():
        return scene.cast_rays(o3d.core.Tensor(rays), nthreads=1)["t_hit"].numpy()

    return _best(build), _best(cast), cast()


def _embreex(vertices, faces, origins, directions):
    def build():
        scene = rtcore_scene.EmbreeScene()
        mesh_construction.TriangleMesh(scene, vertices, faces)
        return scene

    scene = build()
    o, d = origins.astype(np.float32), directions.astype(np.float32)
    def cast():
        return scene.run(o, d, output=1)["tfar"]

    return _best(build), _best(cast), cast()


def main() -> None:
    scenario = load_scenario(ROOT / "scenarios" / "default.yaml")
    clip = capture_motion(scenario.motion, scenario.seed)
    start = float(clip.time_s[0])
    keypoints, _ = interpolate_clip(clip, np.array([start + 0.05]))
    bodies = body_meshes(keypoints[0], clip.team)
    static = build_static_scene()
    ground_v = np.array([[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]], np.float32)
    parts_v = [ground_v, static.vertices] + list(bodies.vertices_m)
    offsets = np.cumsum([0] + [len(v) for v in parts_v])
    parts_f = [np.array([[0, 1, 2], [0, 2, 3]]), static.faces] + [bodies.faces] * len(bodies.vertices_m)
    vertices = np.concatenate(parts_v).astype(np.float32)
    faces = np.concatenate([f + o for f, o in zip(parts_f, offsets)]).astype(np.int32)
    rays = frame_rays(scenario.scan, scenario_sensors(scenario), 0, start)
    # (b): rays aimed at bodies, as many as the renderer moves into part frames in a frame.
    rng = np.random.default_rng(0)
    targets = bodies.vertices_m.reshape(-1, 3)[
        rng.integers(0, bodies.vertices_m.shape[0] * bodies.vertices_m.shape[1], 3000)
    ]
    small_o = np.tile(rays.origin_m[:1], (3000, 1))
    small_d = targets - small_o
    small_d /= np.linalg.norm(small_d, axis=1, keepdims=True)
    rows = []
    for name, origins, directions in (
        ("30,000 frame rays, whole scene", rays.origin_m, rays.direction),
        ("3,000 rays at bodies", small_o, small_d),
    ):
        o3d_build, o3d_cast, o3d_t = _open3d(vertices, faces, origins, directions)
        emb_build, emb_cast, emb_t = _embreex(vertices, faces, origins, directions)
        hit = np.isfinite(o3d_t) & (emb_t < 1e30)
        agree = np.abs(o3d_t[hit] - emb_t[hit]).max() if hit.any() else 0.0
        rows.append(
            [
                name,
                f"{len(faces):,}",
                f"{o3d_build * 1e3:.2f}",
                f"{o3d_cast * 1e3:.2f}",
                f"{emb_build * 1e3:.2f}",
                f"{emb_cast * 1e3:.2f}",
                f"{o3d_cast / emb_cast:.2f}",
                f"{agree:.1e}",
            ]
        )
    write_results(
        "raycasters",
        "Ray casters",
        f"One thread each, best of {REPEATS}. Ratio: Open3D cast time / embreex cast time (above 1: embreex casts "
        "faster). " + machine(open3d=o3d.__version__),
        markdown_table(
            [
                "workload",
                "triangles",
                "Open3D build ms",
                "Open3D cast ms",
                "embreex build ms",
                "embreex cast ms",
                "ratio",
                "max |t| difference, m",
            ],
            rows,
        ),
    )


if __name__ == "__main__":
    main()
