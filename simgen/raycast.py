"""First-hit ray casting with Embree (Open3D's RaycastingScene) for the pitch, static meshes and bodies.

- The ground (z = 0) is solved in closed form: most rays end there and need no mesh.
- Static meshes (goals, nets, boards, stand) sit in one Embree scene built once.
- Bodies are rigid parts (`simgen.body`); their templates sit in a second Embree scene, built once,
  each far from the others. A ray that may hit a part is moved into that part's frame (the
  inverse of the part's rigid pose at the ray's own time slice), started where it enters the
  part's bounding sphere, and cast against the template: one Embree call for all such rays.
  Rigid motions keep ray parameters, so the hit distance needs no conversion.

Ray parameters t are in units of the (unit) direction, i.e. metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d
from numpy.typing import NDArray

TEMPLATE_SPACING_M = 100.0  # templates' distance from each other in their scene


@dataclass(frozen=True)
class Hits:
    """First hits of N rays: t (inf: none), and what was hit."""

    t_m: NDArray[np.float64]  # (N,)
    index: NDArray[np.int64]  # (N,) triangle index, or part index for bodies; -1 for none
    normal: NDArray[np.float64]  # (N, 3) unit surface normal in the pitch frame


def _scene(vertices: NDArray, faces: NDArray) -> o3d.t.geometry.RaycastingScene:
    scene = o3d.t.geometry.RaycastingScene(nthreads=1)
    if len(faces):
        scene.add_triangles(
            o3d.core.Tensor(np.ascontiguousarray(vertices, dtype=np.float32)),
            o3d.core.Tensor(np.ascontiguousarray(faces, dtype=np.uint32)),
        )
    return scene


def _cast(scene, origins: NDArray, directions: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    rays = np.concatenate([origins, directions], axis=1).astype(np.float32)
    result = scene.cast_rays(o3d.core.Tensor(rays), nthreads=1)
    t = result["t_hit"].numpy().astype(np.float64)
    primitive = result["primitive_ids"].numpy().astype(np.int64)
    normal = result["primitive_normals"].numpy().astype(np.float64)
    primitive[~np.isfinite(t)] = -1
    return t, primitive, normal


class StaticCaster:
    """Embree scene of static triangles (pitch frame), built once."""

    def __init__(self, vertices: NDArray, faces: NDArray):
        self.num_faces = len(faces)
        self._scene = _scene(vertices, faces)

    def cast(self, origins: NDArray, directions: NDArray) -> Hits:
        if self.num_faces == 0 or len(origins) == 0:
            n = len(origins)
            return Hits(np.full(n, np.inf), np.full(n, -1, np.int64), np.zeros((n, 3)))
        t, primitive, normal = _cast(self._scene, origins, directions)
        return Hits(t, primitive, normal)


@dataclass(frozen=True)
class PartHits:
    """Hits of (ray, template) pairs on rigid templates."""

    pair: NDArray[np.int64]  # (K,) index of the pair that hit
    ray: NDArray[np.int64]  # (K,) index of the ray
    face: NDArray[np.int64]  # (K,) triangle index over all templates (`PartCaster.face_start`)
    t_m: NDArray[np.float64]  # (K,)
    normal: NDArray[np.float64]  # (K, 3) pitch frame


class PartCaster:
    """Rigid templates in one Embree scene, built once; rays are brought into each template's frame."""

    def __init__(self, templates: list[tuple[NDArray, NDArray]]):
        """templates: (vertices (V, 3) in the template's own frame, faces (F, 3)) each."""
        spacing = TEMPLATE_SPACING_M * np.arange(len(templates))
        self.offset = np.stack([spacing, np.zeros_like(spacing), np.zeros_like(spacing)], axis=1)
        vertex_start = np.cumsum([0] + [len(v) for v, _ in templates])
        self.face_start = np.cumsum([0] + [len(f) for _, f in templates])
        self.centre = np.stack([(v.min(axis=0) + v.max(axis=0)) / 2 for v, _ in templates])
        self.radius = np.array([np.linalg.norm(v - c, axis=1).max() for (v, _), c in zip(templates, self.centre)])
        self._scene = _scene(
            np.concatenate([v + o for (v, _), o in zip(templates, self.offset)]),
            np.concatenate([f + start for (_, f), start in zip(templates, vertex_start)]),
        )

    def cast(self, origins, directions, ray, template, rotation, translation, t_max) -> PartHits:
        """Cast K (ray, template) pairs; the template is posed by rotation (K, 3, 3), translation (K, 3).

        A pair is cast only if its ray enters the template's bounding sphere before t_max[ray], and
        from that point on, so no other template can be reached first; hits beyond t_max are dropped.
        """
        pair = np.arange(len(ray))
        centre_world = np.einsum("kij,kj->ki", rotation, self.centre[template]) + translation
        o, d = origins[ray], directions[ray]
        to_centre = centre_world - o
        t_mid = np.einsum("ki,ki->k", to_centre, d)
        half = np.sqrt(np.clip(self.radius[template] ** 2 - (np.einsum("ki,ki->k", to_centre, to_centre) - t_mid**2), 0, None))
        keep = (half > 0) & (t_mid + half > 0) & (t_mid - half < t_max[ray])
        pair, ray, template, rotation, translation = pair[keep], ray[keep], template[keep], rotation[keep], translation[keep]
        o, d = o[keep], d[keep]
        t_start = np.clip(t_mid[keep] - half[keep], 0, None)
        # Part coordinates: R^T (x - translation), then the template's place in the scene.
        local_o = np.einsum("kji,kj->ki", rotation, o + t_start[:, None] * d - translation) + self.offset[template]
        local_d = np.einsum("kji,kj->ki", rotation, d)
        t, face, normal = _cast(self._scene, local_o, local_d)
        t_total = t + t_start
        own = (face >= self.face_start[template]) & (face < self.face_start[template + 1])
        hit = np.isfinite(t) & own & (t_total < t_max[ray])
        normal_world = np.einsum("kij,kj->ki", rotation[hit], normal[hit])
        return PartHits(pair[hit], ray[hit], face[hit], t_total[hit], normal_world)


def argmin_per_group(num_groups: int, group: NDArray[np.int64], value: NDArray) -> NDArray[np.int64]:
    """Per group (e.g. a ray), the index of its smallest value (e.g. nearest hit); -1 for empty groups."""
    best = np.full(num_groups, -1, dtype=np.int64)
    order = np.lexsort((value, group))
    first = np.ones(len(order), dtype=bool)
    first[1:] = group[order][1:] != group[order][:-1]
    best[group[order][first]] = order[first]
    return best


def sphere_hit(origins: NDArray, directions: NDArray, centres: NDArray, radius: float) -> NDArray[np.float64]:
    """Ray parameter of the first hit of each ray with its own sphere (centres (N, 3)); inf if none."""
    to_centre = centres - origins
    t_mid = np.einsum("ki,ki->k", to_centre, directions)
    half2 = radius**2 - (np.einsum("ki,ki->k", to_centre, to_centre) - t_mid**2)
    t = t_mid - np.sqrt(np.clip(half2, 0, None))
    return np.where((half2 > 0) & (t > 0), t, np.inf)
