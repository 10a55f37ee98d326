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
from simgen.render.noise import noisy_returns, subray_offsets_rad
from simgen.render.raycast import nearest_part_hits, sphere_hit
from simgen.render.world import World
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


def cast(world: World, rays: Rays, rng: np.random.Generator, snapshot_s: float | None = None) -> dict:
    """First hits of every ray: t (inf: none), semantic, instance, reflectivity, cos(incidence); each ray
    meets the scene at its own time, or every ray at `snapshot_s`."""
    n = len(rays.time_s)
    o, d = rays.origin_m, rays.direction
    t, semantic, reflectivity, cos_incidence = _ground_hits(o, d)
    instance = np.full(n, -1, np.int32)
    if n == 0:
        return {"t": t, "semantic": semantic, "instance": instance, "reflectivity": reflectivity,
                "cos_incidence": cos_incidence}

    # Bounding spheres of everything but the ground, per time slice: the H bodies, the ball,
    # then the static objects; each ray meets those of its own slice.
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
    ray, sphere = sphere_candidates(o, d, slice_of_ray - first, t, centres, radius)
    kind, ray_slice = sphere % centres.shape[1], sphere // centres.shape[1]

    # Static meshes; a net lets a ray through with its transmission probability.
    start = np.zeros(n)
    if world.static.num_faces == 0:
        pending = np.zeros(0, np.int64)
    else:
        pending = np.arange(n) if world.cast_all_static else np.unique(ray[kind > num_humanoids])
    for _ in range(MAX_NET_PASSES):
        if len(pending) == 0:
            break
        hits = world.static.cast(o[pending] + start[pending, None] * d[pending], d[pending])
        t_static = hits.t_m + start[pending]
        nearer = np.isfinite(hits.t_m) & (t_static < t[pending])
        through = np.zeros(len(pending), bool)
        nets = nearer & (world.scene.transmission[np.maximum(hits.index, 0)] > 0)
        through[nets] = rng.random(nets.sum()) < world.scene.transmission[hits.index[nets]]
        stop = nearer & ~through
        idx = pending[stop]
        t[idx] = t_static[stop]
        semantic[idx] = world.scene.semantic[hits.index[stop]]
        reflectivity[idx] = world.scene.reflectivity[hits.index[stop]]
        cos_incidence[idx] = _cos_incidence(hits.normal[stop], d[idx])
        start[pending[through]] = t_static[through] + 1e-3
        pending = pending[through]

    # The ball.
    pair = kind == num_humanoids
    ball_ray = ray[pair]
    ball_centre = poses.ball_m[ray_slice[pair]]
    ball_t = sphere_hit(o[ball_ray], d[ball_ray], ball_centre, BALL_RADIUS_M)
    hit = ball_t < t[ball_ray]
    idx = ball_ray[hit]
    t[idx] = ball_t[hit]
    semantic[idx] = BALL
    instance[idx] = BALL_INSTANCE_ID
    reflectivity[idx] = BALL_REFLECTIVITY
    cos_incidence[idx] = _cos_incidence(o[idx] + ball_t[hit, None] * d[idx] - ball_centre[hit], d[idx])

    # The humanoids: every part of each candidate's body, posed at the ray's slice.
    pair = kind < num_humanoids
    if pair.any():
        hits = world.parts.cast(o, d, t, ray[pair], ray_slice[pair], kind[pair], poses.rotation, poses.translation_m)
        template, face = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
        nearest_part_hits(
            hits.ray,
            hits.template,
            hits.t_start_m,
            hits.t_hit_m,
            hits.face,
            hits.normal,
            hits.direction,
            world.parts.face_start,
            t,
            template,
            face,
            cos_incidence,
        )
        got = np.nonzero(template >= 0)[0]
        humanoid = template[got] % num_humanoids
        semantic[got] = world.semantic[humanoid]
        instance[got] = world.clip.track_id[humanoid]
        reflectivity[got] = world.face_reflectivity[face[got]]
    return {"t": t, "semantic": semantic, "instance": instance, "reflectivity": reflectivity,
            "cos_incidence": cos_incidence}


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
    on = noise.enabled
    k, points, intensity, missed, dropped = noisy_returns(
        rays.origin_m,
        rays.direction,
        hit["t"],
        hit["reflectivity"],
        hit["cos_incidence"],
        noise.subrays,
        noise.min_range_m,
        noise.max_range_at_10pct_m,
        noise.dropout if on else 0.0,
        noise.range_sigma_m if on else 0.0,
        np.radians(noise.angle_sigma_deg) if on else 0.0,
        rng,
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
        instance_id=hit["instance"][k],
        semantic=hit["semantic"][k],
        shots=len(rays.time_s),
        dropped=dropped,
        missed=missed,
    )
