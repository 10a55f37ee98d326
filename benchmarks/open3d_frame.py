"""A frame as a user would cast it with Open3D alone: the scene frozen at the frame's middle, rebuilt per frame.

Shared by the baselines of bench_render (only the cast timed) and bench_generate (everything timed): a ground
quad, the scenario's static meshes and every body's mesh posed at mid-frame in one RaycastingScene (one
thread), and the frame's rays as Open3D takes them.
"""

from __future__ import annotations

import numpy as np
import open3d as o3d

from simgen.body.mesh import body_meshes
from simgen.motion.clip import MotionClip
from simgen.motion.interpolate import interpolate_clip
from simgen.scan.rays import Rays
from simgen.scan.sensor import scenario_sensors
from simgen.scan.sensor_rig import frame_rays
from simgen.scenario import Scenario
from simgen.scene.static import StaticScene

GROUND_V = np.array([[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]], np.float32)
GROUND_F = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)


def frozen_frame(
    scenario: Scenario, static: StaticScene, clip: MotionClip, index: int
) -> tuple[o3d.t.geometry.RaycastingScene, Rays, o3d.core.Tensor]:
    """Frame `index` of the clip: its scene (bodies posed at mid-frame), its rays, and the rays as an Open3D tensor."""
    rate = scenario.scan.frame_rate_hz
    start = float(clip.time_s[0]) + index / rate
    keypoints, _ = interpolate_clip(clip, np.array([start + 0.5 / rate]))
    bodies = body_meshes(keypoints[0], clip.team)
    scene = o3d.t.geometry.RaycastingScene(nthreads=1)
    scene.add_triangles(o3d.core.Tensor(GROUND_V), o3d.core.Tensor(GROUND_F))
    scene.add_triangles(o3d.core.Tensor(static.vertices), o3d.core.Tensor(static.faces.astype(np.uint32)))
    for vertices in bodies.vertices_m:
        scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(bodies.faces.astype(np.uint32)))
    rays = frame_rays(scenario.scan, scenario_sensors(scenario), index, float(clip.time_s[0]))
    tensor = o3d.core.Tensor(np.concatenate([rays.origin_m, rays.direction], axis=1).astype(np.float32))
    return scene, rays, tensor
