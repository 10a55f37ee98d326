"""Render one LiDAR frame: cast the shots of a sweep into the posed scene, then apply the sensor's noise.

Every shot keeps its own time: humanoids and the ball are posed per time slice (`simgen.render.world`)
by interpolating the motion clip, so fast players smear as on a real Livox. The frame's point count is exactly its shots
minus random dropouts minus misses (no return, out of range): `ScanFrame` says all three.

Per ray the work is compiled (numba): the analytic ground and its lines, the lookup of the
bounding spheres a ray passes through (`simgen.render.candidates`), preparing and folding back the
rays cast at body parts (`simgen.render.raycast`), and the noise (`simgen.render.noise`). Embree casts only
the rays that may hit a body part or a goal, or every ray when boards or a stand surround the pitch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray

from simgen.render.candidates import sphere_candidates
from simgen.render.noise import noisy_returns, return_model, subray_offsets_rad
from simgen.render.raycast import BodyPairs, NearestPart, PartPoses, RaySpan, nearest_part_hits, sphere_hit
from simgen.render.world import SlicePoses, World
from simgen.scan.rays import Rays
from simgen.scenario import NoiseConfig
from simgen.scene.pitch import on_line_at
from simgen.scene.static import BALL_RADIUS_M, BALL_REFLECTIVITY, GRASS_REFLECTIVITY, LINE_REFLECTIVITY
from simgen.vocab import BALL, BALL_INSTANCE_ID, GROUND, LINE

MAX_NET_PASSES = 3


@dataclass(frozen=True)
class ScanFrame:
    """The points of one frame, pitch frame, and how the shots were spent."""

    points_m: NDArray[np.float32]  # (P, 3)
    intensity: NDArray[np.uint8]  # (P,) 0-255 (Livox calibrated reflectivity: 0-150 diffuse)
    time_offset_s: NDArray[np.float32]  # (P,) since the frame's start
    sensor: NDArray[np.uint8]  # (P,)
    head: NDArray[np.uint8]  # (P,)
    instance_id: NDArray[np.int32]  # (P,) track id, BALL_INSTANCE_ID, or -1
    semantic: NDArray[np.uint8]  # (P,) index into simgen.vocab.SEMANTIC_NAMES
    shots: int
    dropped: int  # returns lost to random dropout
    missed: int  # shots with no return in range (sky, too near, too far for the reflectivity)
    sweep: NDArray[np.uint8] = field(default=None)  # (P,) sweep of the frame the shot belongs to; default all 0
    line: NDArray[np.uint8] = field(default=None)  # (P,) laser of the head that fired the shot; default all 0

    def __post_init__(self) -> None:
        if self.sweep is None:  # one sweep per frame
            object.__setattr__(self, "sweep", np.zeros(len(self.points_m), np.uint8))
        if self.line is None:  # one laser per head
            object.__setattr__(self, "line", np.zeros(len(self.points_m), np.uint8))


def expand_subrays(rays: Rays, noise: NoiseConfig) -> Rays:
    """Each shot as `noise.subrays` consecutive rays spread over the beam footprint."""
    offsets = subray_offsets_rad(noise)
    if len(offsets) == 1:
        return rays
    d = rays.direction
    horizontal = np.cross(d, [0.0, 0.0, 1.0])
    horizontal /= np.linalg.norm(horizontal, axis=1, keepdims=True)
    vertical = np.cross(horizontal, d)
    spread = (
        d[:, None] + offsets[None, :, 0, None] * horizontal[:, None] + offsets[None, :, 1, None] * vertical[:, None]
    )
    spread /= np.linalg.norm(spread, axis=2, keepdims=True)
    shot = np.repeat(np.arange(len(d)), len(offsets))
    return Rays(
        rays.origin_m[shot],
        spread.reshape(-1, 3),
        rays.time_s[shot],
        rays.sensor[shot],
        rays.head[shot],
        rays.sweep[shot],
        rays.line[shot],
    )


@numba.njit(cache=True)
def _ground_hits(origins, directions):
    """Per ray: t (metres; inf for rays not going down), semantic (ground or line), reflectivity, |cos incidence|."""
    n = len(origins)
    t = np.full(n, np.inf)
    semantic = np.full(n, GROUND, np.uint8)
    reflectivity = np.full(n, GRASS_REFLECTIVITY)
    cos_incidence = np.empty(n)
    for i in range(n):
        dz = directions[i, 2]
        cos_incidence[i] = abs(dz)  # the ground's normal is +z
        if dz < 0.0:
            t[i] = -origins[i, 2] / dz
            if on_line_at(origins[i, 0] + t[i] * directions[i, 0], origins[i, 1] + t[i] * directions[i, 1]):
                semantic[i] = LINE
                reflectivity[i] = LINE_REFLECTIVITY
    return t, semantic, reflectivity, cos_incidence


def _cos_incidence(normals: NDArray, directions: NDArray) -> NDArray[np.float64]:
    """|cos| of the angle between surface normals (any length) and unit ray directions."""
    return np.abs(np.einsum("ni,ni->n", normals, directions)) / np.linalg.norm(normals, axis=1)


@dataclass(frozen=True)
class Hits:
    """The first hit of each of N rays, nearest so far while the stages of `cast` fill it in place."""

    t_m: NDArray[np.float64]  # (N,) metres along the ray; inf: none
    semantic: NDArray[np.uint8]  # (N,) index into simgen.vocab.SEMANTIC_NAMES
    instance: NDArray[np.int32]  # (N,) track id, BALL_INSTANCE_ID, or -1
    reflectivity: NDArray[np.float64]  # (N,) 0-1
    cos_incidence: NDArray[np.float64]  # (N,) |cos| of the angle between the ray and the surface's normal


@dataclass(frozen=True)
class Candidates:
    """The (ray, sphere) pairs of `sphere_candidates` over one cast's slices, and the poses they refer to."""

    ray: NDArray[np.int64]  # (Q,)
    kind: NDArray[np.int64]  # (Q,) 0 .. H - 1 a humanoid, H the ball, above it a static object's sphere
    ray_slice: NDArray[np.int64]  # (Q,) index into `poses`' slices
    poses: SlicePoses
    num_humanoids: int


def ground_hits(rays: Rays) -> Hits:
    """Every ray's hit on the ground (z = 0) and its painted lines, in closed form; no instance."""
    t, semantic, reflectivity, cos_incidence = _ground_hits(rays.origin_m, rays.direction)
    return Hits(t, semantic, np.full(len(t), -1, np.int32), reflectivity, cos_incidence)


def candidates(world: World, rays: Rays, t_max_m: NDArray, snapshot_s: float | None) -> Candidates:
    """Which rays pass through which bounding spheres before `t_max_m`: the H bodies', the ball's and the
    static objects', each ray those of its own time slice (every ray the one slice at `snapshot_s`)."""
    n = len(rays.time_s)
    if snapshot_s is None:
        slice_of_ray = world.slice_index(rays.time_s)
        first = int(slice_of_ray.min())
        poses = world.poses(first, int(slice_of_ray.max()) - first + 1)
    else:
        slice_of_ray, first, poses = np.zeros(n, np.int64), 0, world.pose_at(snapshot_s)
    num_slices, num_humanoids = poses.middle_m.shape[:2]
    statics = world.static_spheres
    centres = np.concatenate(
        [poses.middle_m, poses.ball_m[:, None], np.broadcast_to(statics[:, :3], (num_slices, len(statics), 3))], axis=1
    )
    radius = np.concatenate(
        [
            poses.reach_m,
            np.full((num_slices, 1), BALL_RADIUS_M),
            np.broadcast_to(statics[:, 3], (num_slices, len(statics))),
        ],
        axis=1,
    )
    ray, sphere = sphere_candidates(rays.origin_m, rays.direction, slice_of_ray - first, t_max_m, centres, radius)
    return Candidates(ray, sphere % centres.shape[1], sphere // centres.shape[1], poses, num_humanoids)


def static_hits(world: World, rays: Rays, near: Candidates, hits: Hits, rng: np.random.Generator) -> None:
    """Fold in the static meshes' hits (goals, nets, boards, stand): a net lets a ray through with its
    transmission probability, drawn from `rng`, at most MAX_NET_PASSES times."""
    o, d, t = rays.origin_m, rays.direction, hits.t_m
    n = len(t)
    start = np.zeros(n)
    if world.static.num_faces == 0:
        pending = np.zeros(0, np.int64)
    else:
        pending = np.arange(n) if world.cast_all_static else np.unique(near.ray[near.kind > near.num_humanoids])
    for _ in range(MAX_NET_PASSES):
        if len(pending) == 0:
            break
        mesh = world.static.cast(o[pending] + start[pending, None] * d[pending], d[pending])
        t_static = mesh.t_m + start[pending]
        nearer = np.isfinite(mesh.t_m) & (t_static < t[pending])
        through = np.zeros(len(pending), bool)
        nets = nearer & (world.scene.transmission[np.maximum(mesh.index, 0)] > 0)
        through[nets] = rng.random(nets.sum()) < world.scene.transmission[mesh.index[nets]]
        stop = nearer & ~through
        idx = pending[stop]
        t[idx] = t_static[stop]
        hits.semantic[idx] = world.scene.semantic[mesh.index[stop]]
        hits.reflectivity[idx] = world.scene.reflectivity[mesh.index[stop]]
        hits.cos_incidence[idx] = _cos_incidence(mesh.normal[stop], d[idx])
        start[pending[through]] = t_static[through] + 1e-3
        pending = pending[through]


def ball_hits(rays: Rays, near: Candidates, hits: Hits) -> None:
    """Fold in the ball's hits: an analytic sphere at each ray's slice."""
    o, d = rays.origin_m, rays.direction
    pair = near.kind == near.num_humanoids
    ball_ray = near.ray[pair]
    ball_centre = near.poses.ball_m[near.ray_slice[pair]]
    ball_t = sphere_hit(o[ball_ray], d[ball_ray], ball_centre, BALL_RADIUS_M)
    hit = ball_t < hits.t_m[ball_ray]
    idx = ball_ray[hit]
    hits.t_m[idx] = ball_t[hit]
    hits.semantic[idx] = BALL
    hits.instance[idx] = BALL_INSTANCE_ID
    hits.reflectivity[idx] = BALL_REFLECTIVITY
    hits.cos_incidence[idx] = _cos_incidence(o[idx] + ball_t[hit, None] * d[idx] - ball_centre[hit], d[idx])


def humanoid_hits(world: World, rays: Rays, near: Candidates, hits: Hits) -> None:
    """Fold in the humanoids' hits: every part of each candidate's body, posed at the ray's slice."""
    pair = near.kind < near.num_humanoids
    if not pair.any():
        return
    n = len(hits.t_m)
    parts = world.parts.cast(
        RaySpan(rays.origin_m, rays.direction, hits.t_m),
        BodyPairs(near.ray[pair], near.ray_slice[pair], near.kind[pair]),
        PartPoses(near.poses.rotation, near.poses.translation_m),
    )
    nearest = NearestPart(hits.t_m, np.full(n, -1, np.int64), np.full(n, -1, np.int64), hits.cos_incidence)
    nearest_part_hits(parts, world.parts.face_start, nearest)
    got = np.nonzero(nearest.template >= 0)[0]
    humanoid = nearest.template[got] % near.num_humanoids
    hits.semantic[got] = world.semantic[humanoid]
    hits.instance[got] = world.clip.track_id[humanoid]
    hits.reflectivity[got] = world.face_reflectivity[nearest.face[got]]


def cast(world: World, rays: Rays, rng: np.random.Generator, snapshot_s: float | None = None) -> Hits:
    """First hits of every ray, each meeting the scene at its own time, or every ray at `snapshot_s`:
    the ground, then the static meshes, the ball and the humanoids, each stage keeping the nearer hit."""
    hits = ground_hits(rays)
    if len(hits.t_m) == 0:
        return hits
    near = candidates(world, rays, hits.t_m, snapshot_s)
    static_hits(world, rays, near, hits, rng)
    ball_hits(rays, near, hits)
    humanoid_hits(world, rays, near, hits)
    return hits


def render_frame(
    world: World,
    rays: Rays,
    frame_start_s: float,
    noise: NoiseConfig,
    rng: np.random.Generator,
    snapshot_s: float | None = None,
) -> ScanFrame:
    """Cast a sweep's shots, keep each shot's nearest return in range, and apply the noise model.

    `snapshot_s`: every shot meets the scene as it is at that one instant, and every point carries
    that time (`scan.timing: snapshot`, the paper's sampling of a depth map); otherwise each shot
    meets it at its own time (a real Livox's sweep, `scan.timing: sweep`)."""
    hit = cast(world, expand_subrays(rays, noise), rng, snapshot_s)
    k, points, intensity, missed, dropped = noisy_returns(
        rays.origin_m, rays.direction, hit.t_m, hit.reflectivity, hit.cos_incidence, return_model(noise), rng
    )
    shot = k // noise.subrays
    return ScanFrame(
        points_m=points,
        intensity=intensity,
        time_offset_s=(
            (rays.time_s[shot] if snapshot_s is None else np.full(len(shot), snapshot_s)) - frame_start_s
        ).astype(np.float32),
        sensor=rays.sensor[shot],
        head=rays.head[shot],
        sweep=rays.sweep[shot],
        line=rays.line[shot],
        instance_id=hit.instance[k],
        semantic=hit.semantic[k],
        shots=len(rays.time_s),
        dropped=dropped,
        missed=missed,
    )
