"""First-hit ray casting with Embree (Open3D's RaycastingScene) for the pitch, static meshes and bodies.

- The ground (z = 0) is solved in closed form: most rays end there and need no mesh.
- Static meshes (goals, nets, boards, stand) sit in one Embree scene built once.
- Bodies are rigid parts (`simgen.body.mesh`); their templates sit in a second Embree scene, built once,
  on a grid with their bounding spheres apart. A ray that may hit a part is moved into that part's frame (the
  inverse of the part's rigid pose at the ray's own time slice), started where it enters the
  part's bounding sphere, and cast against the template: one Embree call for all such rays.
  Rigid motions keep ray parameters, so the hit distance needs no conversion. A hit is the ray's
  own template's only if Embree's first hit is on it: other templates lie beyond its sphere.
  Preparing those rays and folding the hits back are compiled loops (numba).

Ray parameters t are in units of the (unit) direction, i.e. metres.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
import open3d as o3d
from numpy.typing import NDArray

from simgen.render.buffers import grow

TEMPLATE_GAP_M = 0.5  # between the bounding spheres of templates in their scene
BOX_MARGIN_M = 1e-4  # round each template's box, against rounding


@dataclass(frozen=True)
class MeshHits:
    """First hits of N rays on a static mesh: t (inf: none), and what was hit."""

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


class RaySpan(NamedTuple):
    """N rays and how far along each to look (a NamedTuple: compiled loops take it whole)."""

    origin_m: NDArray[np.float64]  # (N, 3) pitch frame
    direction: NDArray[np.float64]  # (N, 3) unit
    t_max_m: NDArray[np.float64]  # (N,) nearest hit so far


class BodyPairs(NamedTuple):
    """(ray, time slice, humanoid) pairs whose ray passes through the humanoid's bounding sphere."""

    ray: NDArray[np.int64]  # (Q,)
    time_slice: NDArray[np.int64]  # (Q,) index into the poses' slices
    humanoid: NDArray[np.int64]  # (Q,)


class PartPoses(NamedTuple):
    """Every humanoid's rigid parts at S time slices (`simgen.render.world.SlicePoses`)."""

    rotation: NDArray[np.float64]  # (S, H, P, 3, 3) part -> pitch coordinates
    translation_m: NDArray[np.float64]  # (S, H, P, 3)


class TemplateBounds(NamedTuple):
    """Each template's bounds in its own frame and its place in the templates' scene (T templates)."""

    centre: NDArray[np.float64]  # (T, 3) bounding sphere's centre
    radius: NDArray[np.float64]  # (T,) bounding sphere's radius
    low: NDArray[np.float64]  # (T, 3) box round the template
    high: NDArray[np.float64]  # (T, 3)
    offset: NDArray[np.float64]  # (T, 3) template -> scene coordinates


class PartHits(NamedTuple):
    """What Embree returned for the K rays cast at templates, in template coordinates."""

    ray: NDArray[np.int64]  # (K,) index of the ray
    template: NDArray[np.int64]  # (K,)
    t_start_m: NDArray[np.float64]  # (K,) where the cast began along the ray
    t_hit_m: NDArray[np.float32]  # (K,) from t_start; inf: none
    face: NDArray[np.uint32]  # (K,) triangle index over all templates (`PartCaster.face_start`)
    normal: NDArray[np.float32]  # (K, 3) template frame
    direction: NDArray[np.float32]  # (K, 3) the ray's direction, template frame


class NearestPart(NamedTuple):
    """Per ray, the nearest part hit so far, filled in place by `nearest_part_hits`."""

    t_m: NDArray[np.float64]  # (N,) inf: none
    template: NDArray[np.int64]  # (N,) -1: none
    face: NDArray[np.int64]  # (N,) -1: none
    cos_incidence: NDArray[np.float64]  # (N,) |cos| of the incidence angle


class StaticCaster:
    """Embree scene of static triangles (pitch frame), built once."""

    def __init__(self, vertices: NDArray, faces: NDArray):
        self.num_faces = len(faces)
        self._scene = _scene(vertices, faces)

    def cast(self, origins: NDArray, directions: NDArray) -> MeshHits:
        if self.num_faces == 0 or len(origins) == 0:
            n = len(origins)
            return MeshHits(np.full(n, np.inf), np.full(n, -1, np.int64), np.zeros((n, 3)))
        t, primitive, normal = _cast(self._scene, origins, directions)
        return MeshHits(t, primitive, normal)


class PartCaster:
    """Rigid templates in one Embree scene, built once; rays are brought into each template's frame."""

    def __init__(self, templates: list[tuple[NDArray, NDArray]]):
        """templates: (vertices (V, 3) in the template's own frame, faces (F, 3)) each."""
        vertex_start = np.cumsum([0] + [len(v) for v, _ in templates])
        self.face_start = np.cumsum([0] + [len(f) for _, f in templates])
        low = np.stack([v.min(axis=0) for v, _ in templates]) - BOX_MARGIN_M  # box round each template
        high = np.stack([v.max(axis=0) for v, _ in templates]) + BOX_MARGIN_M
        centre = (low + high) / 2
        radius = np.array([np.linalg.norm(v - c, axis=1).max() for (v, _), c in zip(templates, centre)]) + BOX_MARGIN_M
        # Templates on a cubic grid, their bounding spheres apart, near the scene's origin (float32).
        side = int(np.ceil(len(templates) ** (1 / 3)))
        cell = np.stack(np.unravel_index(np.arange(len(templates)), (side, side, side)), axis=1)
        offset = cell * (2 * radius.max() + TEMPLATE_GAP_M) - centre
        self.bounds = TemplateBounds(centre, radius, low, high, offset)
        self._scene = _scene(
            np.concatenate([v + o for (v, _), o in zip(templates, offset)]),
            np.concatenate([f + start for (_, f), start in zip(templates, vertex_start)]),
        )

    def cast(self, rays: RaySpan, pairs: BodyPairs, poses: PartPoses) -> PartHits:
        """Cast every part of the humanoid of each (ray, slice, humanoid) pair, posed at that slice;
        template p * H + h.

        A part is cast only if the ray enters its bounding sphere, then its box, before t_max[ray],
        and from the box on, so no other template can be reached first; hits beyond t_max are dropped.
        """
        local, ray, template, t_start = _part_rays(rays, pairs, poses, self.bounds)
        result = self._scene.cast_rays(o3d.core.Tensor(local), nthreads=1)
        return PartHits(
            ray,
            template,
            t_start,
            result["t_hit"].numpy(),
            result["primitive_ids"].numpy(),
            result["primitive_normals"].numpy(),
            local[:, 3:],
        )


@numba.njit(cache=True)
def _part_rays(rays: RaySpan, pairs: BodyPairs, poses: PartPoses, bounds: TemplateBounds):
    """Per (pair, part) whose bounding sphere, then box (in part coordinates), the ray enters before
    its t_max: the ray in template coordinates from its box entry, (K, 6) float32 origin + direction,
    its ray, template and t_start."""
    o, d, t_max = rays
    pair_ray, pair_slice, pair_humanoid = pairs
    rotation, translation = poses
    centre, radius, low, high, offset = bounds
    num_slices, num_humanoids, num_parts = rotation.shape[:3]
    # Bounding-sphere centres of the posed parts, pitch frame.
    centre_world = np.empty((num_slices, num_humanoids, num_parts, 3))
    for s in range(num_slices):
        for h in range(num_humanoids):
            for p in range(num_parts):
                j = p * num_humanoids + h
                for a in range(3):
                    centre_world[s, h, p, a] = (
                        rotation[s, h, p, a, 0] * centre[j, 0]
                        + rotation[s, h, p, a, 1] * centre[j, 1]
                        + rotation[s, h, p, a, 2] * centre[j, 2]
                        + translation[s, h, p, a]
                    )
    capacity = max(16, 2 * len(pair_ray))
    local = np.empty((capacity, 6), np.float32)
    ray = np.empty(capacity, np.int64)
    template = np.empty(capacity, np.int64)
    t_start = np.empty(capacity, np.float64)
    local_ray = np.empty(6)
    count = 0
    for k in range(len(pair_ray)):
        i, s, h = pair_ray[k], pair_slice[k], pair_humanoid[k]
        for p in range(num_parts):
            j = p * num_humanoids + h
            cx = centre_world[s, h, p, 0] - o[i, 0]
            cy = centre_world[s, h, p, 1] - o[i, 1]
            cz = centre_world[s, h, p, 2] - o[i, 2]
            t_mid = cx * d[i, 0] + cy * d[i, 1] + cz * d[i, 2]
            half2 = radius[j] ** 2 - (cx * cx + cy * cy + cz * cz - t_mid * t_mid)
            if half2 <= 0.0:
                continue
            half = np.sqrt(half2)
            if t_mid + half <= 0.0 or t_mid - half >= t_max[i]:
                continue
            # Part coordinates: R^T (x - translation); then the slab test against the part's box.
            R, x = rotation[s, h, p], translation[s, h, p]
            px, py, pz = o[i, 0] - x[0], o[i, 1] - x[1], o[i, 2] - x[2]
            start, stop = 0.0, t_max[i]
            for a in range(3):
                origin_a = R[0, a] * px + R[1, a] * py + R[2, a] * pz
                direction_a = R[0, a] * d[i, 0] + R[1, a] * d[i, 1] + R[2, a] * d[i, 2]
                local_ray[a], local_ray[3 + a] = origin_a, direction_a
                if direction_a != 0.0:
                    near, far = (low[j, a] - origin_a) / direction_a, (high[j, a] - origin_a) / direction_a
                    start, stop = max(start, min(near, far)), min(stop, max(near, far))
                elif not low[j, a] <= origin_a <= high[j, a]:
                    stop = -1.0
            if start >= stop:
                continue
            if count == capacity:
                capacity *= 2
                local = grow(local, capacity)
                ray, template, t_start = grow(ray, capacity), grow(template, capacity), grow(t_start, capacity)
            for a in range(3):
                local[count, a] = local_ray[a] + start * local_ray[3 + a] + offset[j, a]
                local[count, 3 + a] = local_ray[3 + a]
            ray[count], template[count], t_start[count] = i, j, start
            count += 1
    return local[:count], ray[:count], template[:count], t_start[:count]


@numba.njit(cache=True)
def nearest_part_hits(hits: PartHits, face_start: NDArray[np.int64], nearest: NearestPart) -> None:
    """Fold part hits into the rays' nearest hits so far: where a hit on the ray's own template (its
    faces face_start[j] .. face_start[j + 1] - 1) lies nearer than nearest.t_m[ray], set `nearest`'s
    t_m, template, face and |cos| of the incidence angle (in place)."""
    hits_ray, hits_template, t_start, t_hit, face, normal, direction = hits
    t_m, hit_template, hit_face, cos_incidence = nearest
    for k in range(len(hits_ray)):
        j = hits_template[k]
        if not (np.isfinite(t_hit[k]) and face_start[j] <= face[k] < face_start[j + 1]):
            continue
        i = hits_ray[k]
        t = t_start[k] + t_hit[k]
        if t < t_m[i]:
            n = normal[k]
            length = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
            t_m[i], hit_template[i], hit_face[i] = t, j, face[k]
            cos_incidence[i] = abs(n[0] * direction[k, 0] + n[1] * direction[k, 1] + n[2] * direction[k, 2]) / length


def sphere_hit(origins: NDArray, directions: NDArray, centres: NDArray, radius: float) -> NDArray[np.float64]:
    """Ray parameter of the first hit of each ray with its own sphere (centres (N, 3)); inf if none."""
    to_centre = centres - origins
    t_mid = np.einsum("ki,ki->k", to_centre, directions)
    half2 = radius**2 - (np.einsum("ki,ki->k", to_centre, to_centre) - t_mid**2)
    t = t_mid - np.sqrt(np.clip(half2, 0, None))
    return np.where((half2 > 0) & (t > 0), t, np.inf)
