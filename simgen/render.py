"""Render one LiDAR frame: cast the shots of a sweep into the posed scene, then apply the sensor's noise.

Every shot keeps its own time: humanoids and the ball are posed per time slice (at most 10 ms) by
interpolating the motion clip, so fast players smear as on a real Livox. The frame's point count
is exactly its shots minus random dropouts minus misses (no return, out of range): `ScanFrame`
says all three.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.body import REFLECTIVITY, TEAM_NAMES, part_frames, part_templates
from simgen.motion import MotionClip
from simgen.noise import NoiseConfig, intensity, jitter_directions, max_range_m, subray_offsets_rad
from simgen.pitch import ground_hit, on_line
from simgen.raycast import PartCaster, StaticCaster, argmin_per_group, sphere_hit
from simgen.scene import (
    BALL,
    GOAL,
    SURROUNDINGS,
    BALL_RADIUS_M,
    BALL_REFLECTIVITY,
    GRASS_REFLECTIVITY,
    GROUND,
    LINE,
    LINE_REFLECTIVITY,
    OFFICIAL,
    PLAYER,
    StaticScene,
)
from simgen.skeleton import KEYPOINT_INDEX

SLICE_S = 0.01  # longest time over which a humanoid keeps one pose within a sweep
BALL_INSTANCE_ID = 1000  # instance id of the ball's points (humanoids: their track id; others: -1)
MAX_NET_PASSES = 3
REACH_MARGIN_M = 0.05  # a pose between two captured ones may reach a little further than either


@dataclass(frozen=True)
class Rays:
    """Shots of one sweep in the pitch frame."""

    origin_m: NDArray[np.float64]  # (N, 3)
    direction: NDArray[np.float64]  # (N, 3) unit
    time_s: NDArray[np.float64]  # (N,) game time of each shot
    sensor: NDArray[np.uint8]  # (N,) index of the sensor in the scenario
    head: NDArray[np.uint8]  # (N,) index of the head in its sensor


@dataclass(frozen=True)
class ScanFrame:
    """The points of one frame, pitch frame, and how the shots were spent."""

    points_m: NDArray[np.float32]  # (P, 3)
    intensity: NDArray[np.uint8]  # (P,) 0-255 (Livox calibrated reflectivity: 0-150 diffuse)
    time_offset_s: NDArray[np.float32]  # (P,) since the frame's start
    sensor: NDArray[np.uint8]  # (P,)
    head: NDArray[np.uint8]  # (P,)
    instance_id: NDArray[np.int32]  # (P,) track id, BALL_INSTANCE_ID, or -1
    semantic: NDArray[np.uint8]  # (P,) index into simgen.scene.SEMANTIC_NAMES
    shots: int
    dropped: int  # returns lost to random dropout
    missed: int  # shots with no return in range (sky, too near, too far for the reflectivity)


def interpolate_clip(clip: MotionClip, times_s: NDArray) -> tuple[NDArray, NDArray]:
    """Keypoints (T, H, 12, 3) and ball (T, 3) at `times_s`, linear between captured frames."""
    times = np.asarray(times_s, dtype=np.float64)
    if len(times) and (times.min() < clip.time_s[0] - 1e-9 or times.max() > clip.time_s[-1] + 1e-9):
        raise ValueError(f"times {times.min():.3f}-{times.max():.3f} s outside the clip's {clip.time_s[0]:.3f}-{clip.time_s[-1]:.3f} s")
    upper = np.clip(np.searchsorted(clip.time_s, times, side="right"), 1, clip.num_frames - 1)
    lower = upper - 1
    span = clip.time_s[upper] - clip.time_s[lower]
    w = np.clip((times - clip.time_s[lower]) / span, 0.0, 1.0)
    kp0, kp1 = clip.keypoints_m[lower].astype(np.float64), clip.keypoints_m[upper].astype(np.float64)
    ball0, ball1 = clip.ball_m[lower].astype(np.float64), clip.ball_m[upper].astype(np.float64)
    return kp0 + w[:, None, None, None] * (kp1 - kp0), ball0 + w[:, None] * (ball1 - ball0)


class World:
    """What stays the same over a clip: the static scene, and every humanoid's rigid part meshes."""

    def __init__(self, clip: MotionClip, scene: StaticScene):
        self.clip = clip
        self.scene = scene
        self.static = StaticCaster(scene.vertices, scene.faces)
        self.team_index = np.array([TEAM_NAMES.index(t) for t in clip.team])
        templates = part_templates(clip.keypoints_m[0].astype(np.float64), clip.team)
        # One template per (part, humanoid): template p * H + h.
        self.num_parts = len(templates)
        self.parts = PartCaster([(local[h], faces) for local, faces, _ in templates for h in range(clip.num_humanoids)])
        self.face_reflectivity = np.concatenate([REFLECTIVITY[materials].reshape(-1) for _, _, materials in templates])
        # Each humanoid's reach from `middle` over the clip: the radius of its bounding sphere.
        rotation, origin = part_frames(clip.keypoints_m.reshape(-1, 12, 3).astype(np.float64))
        humanoid = np.arange(len(origin)) % clip.num_humanoids
        template = np.arange(self.num_parts)[None] * clip.num_humanoids + humanoid[:, None]
        part_centres = np.einsum("ipjk,ipk->ipj", rotation, self.parts.centre[template]) + origin
        middle = clip.keypoints_m.reshape(-1, 12, 3)[:, KEYPOINT_INDEX["middle"]]
        reach = (np.linalg.norm(part_centres - middle[:, None], axis=2) + self.parts.radius[template]).max(axis=1)
        self.body_radius = reach.reshape(clip.num_frames, clip.num_humanoids).max(axis=0) + REACH_MARGIN_M
        self.semantic = np.where(clip.team == "official", OFFICIAL, PLAYER).astype(np.uint8)
        # Goals are small seen from a sensor: only rays through their bounding spheres are cast at
        # them. Boards and a stand surround the sensor: with them, every ray is cast.
        self.cast_all_static = bool((scene.semantic == SURROUNDINGS).any())
        spheres = []
        for side in (-1.0, 1.0):
            faces = scene.faces[(scene.semantic == GOAL) & (np.sign(scene.vertices[scene.faces[:, 0], 0]) == side)]
            if len(faces):
                vertices = scene.vertices[faces.reshape(-1)].astype(np.float64)
                centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
                spheres.append((*centre, np.linalg.norm(vertices - centre, axis=1).max() + 1e-3))
        self.static_spheres = np.array(spheres, dtype=np.float64).reshape(-1, 4)


def expand_subrays(rays: Rays, noise: NoiseConfig) -> tuple[Rays, NDArray[np.int64]]:
    """Each shot as `noise.subrays` rays spread over the beam footprint; returns them and their shot."""
    offsets = subray_offsets_rad(noise)
    if len(offsets) == 1:
        return rays, np.arange(len(rays.time_s))
    d = rays.direction
    horizontal = np.cross(d, [0.0, 0.0, 1.0])
    horizontal /= np.linalg.norm(horizontal, axis=1, keepdims=True)
    vertical = np.cross(horizontal, d)
    spread = d[:, None] + offsets[None, :, 0, None] * horizontal[:, None] + offsets[None, :, 1, None] * vertical[:, None]
    spread /= np.linalg.norm(spread, axis=2, keepdims=True)
    count = len(offsets)
    shot = np.repeat(np.arange(len(d)), count)
    expanded = Rays(
        np.repeat(rays.origin_m, count, axis=0), spread.reshape(-1, 3), rays.time_s[shot], rays.sensor[shot], rays.head[shot]
    )
    return expanded, shot


def _ranges(starts: NDArray[np.int64], stops: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Concatenated aranges [starts[i], stops[i]) and, for each element, its i."""
    lengths = np.maximum(stops - starts, 0)
    which = np.repeat(np.arange(len(starts)), lengths)
    offsets = np.arange(lengths.sum()) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    return starts[which] + offsets, which


ELEVATION_BIN_RAD = np.radians(2.0)  # rays are bucketed by elevation band, then sorted by azimuth


def sphere_candidates(origins, directions, sensor, centres, radius, slice_of_ray, t_max) -> tuple[NDArray, NDArray]:
    """(ray, sphere) pairs whose ray passes through the sphere before t_max[ray].

    centres (S, M, 3) and radius (S, M): M spheres per time slice; a ray of slice s meets only the
    spheres of slice s; sphere = s * M + m. Rays are sorted by (origin, slice, 2-degree elevation
    band, azimuth); each sphere looks up, in each band it spans, only the rays of its azimuth
    interval as seen from each origin (one per sensor), so the cost grows with the rays and the
    candidates, not rays x spheres.
    """
    num_slices, num_spheres = radius.shape
    sensors, first = np.unique(sensor, return_index=True)
    unique_origins = origins[first]
    elevation = np.arcsin(np.clip(directions[:, 2], -1, 1))
    num_bands = int(np.ceil(np.pi / ELEVATION_BIN_RAD)) + 1
    band = ((elevation + np.pi / 2) / ELEVATION_BIN_RAD).astype(np.int64)
    group = (np.searchsorted(sensors, sensor) * num_slices + slice_of_ray) * num_bands + band
    azimuth = np.arctan2(directions[:, 1], directions[:, 0]) + np.pi  # [0, 2 pi]
    width = 2 * np.pi + 1.0
    key = group * width + azimuth
    order = np.argsort(key)
    sorted_key = key[order]
    # Each sphere seen from each origin: azimuth interval and elevation bands.
    to_centre = centres[None] - unique_origins[:, None, None]  # (O, S, M, 3)
    distance = np.linalg.norm(to_centre, axis=-1)
    distance_xy = np.hypot(to_centre[..., 0], to_centre[..., 1])
    centre_azimuth = np.arctan2(to_centre[..., 1], to_centre[..., 0]) + np.pi
    half = np.where(distance_xy > radius, np.arcsin(np.minimum(radius / np.maximum(distance_xy, 1e-9), 1)), np.pi)
    angular = np.arcsin(np.minimum(radius / np.maximum(distance, 1e-9), 1))
    centre_elevation = np.arcsin(np.clip(to_centre[..., 2] / np.maximum(distance, 1e-9), -1, 1))
    inside = distance <= radius
    low_band = np.where(inside, 0, ((centre_elevation - angular + np.pi / 2) / ELEVATION_BIN_RAD).astype(np.int64).clip(0, num_bands - 1))
    high_band = np.where(inside, num_bands - 1, ((centre_elevation + angular + np.pi / 2) / ELEVATION_BIN_RAD).astype(np.int64).clip(0, num_bands - 1))
    sphere_id = np.broadcast_to(np.arange(num_slices * num_spheres).reshape(num_slices, num_spheres), half.shape).reshape(-1)
    origin_slice = (np.arange(len(unique_origins))[:, None] * num_slices + np.arange(num_slices)[None])[..., None]
    origin_slice = np.broadcast_to(origin_slice, half.shape).reshape(-1)
    # One query per (origin, slice, sphere, band).
    bands_per = (high_band - low_band + 1).reshape(-1)
    query = np.repeat(np.arange(len(bands_per)), bands_per)
    query_band = low_band.reshape(-1)[query] + np.arange(len(query)) - np.repeat(np.cumsum(bands_per) - bands_per, bands_per)
    base = (origin_slice[query] * num_bands + query_band) * width
    low = (centre_azimuth - half).reshape(-1)[query]
    high = (centre_azimuth + half).reshape(-1)[query]
    # Split intervals that wrap round 0 / 2 pi into two; clip to [0, 2 pi].
    pieces = [(np.maximum(low, 0), np.minimum(high, 2 * np.pi)), (low + 2 * np.pi, np.full_like(low, 2 * np.pi)), (np.zeros_like(high), high - 2 * np.pi)]
    rays_out, spheres_out = [], []
    for lo, hi in pieces:
        valid = hi > lo
        starts = np.searchsorted(sorted_key, (base + lo)[valid])
        stops = np.searchsorted(sorted_key, (base + hi)[valid], side="right")
        position, which = _ranges(starts, stops)
        rays_out.append(order[position])
        spheres_out.append(sphere_id[query[valid]][which])
    ray, sphere = np.concatenate(rays_out), np.concatenate(spheres_out)
    # Exact test against the sphere, in front of the nearest hit so far.
    to_centre = centres.reshape(-1, 3)[sphere] - origins[ray]
    t_mid = np.einsum("ki,ki->k", to_centre, directions[ray])
    miss2 = np.einsum("ki,ki->k", to_centre, to_centre) - t_mid**2
    r = radius.reshape(-1)[sphere]
    near = (miss2 < r**2) & (t_mid > -r) & (t_mid - r < t_max[ray])
    return ray[near], sphere[near]


def _cos_incidence(normals: NDArray, directions: NDArray) -> NDArray[np.float64]:
    """|cos| of the angle between surface normals (any length) and unit ray directions."""
    return np.abs(np.einsum("ni,ni->n", normals, directions)) / np.linalg.norm(normals, axis=1)


def cast(world: World, rays: Rays, frame_start_s: float, rng: np.random.Generator) -> dict:
    """First hits of every ray: t (inf: none), semantic, instance, reflectivity, cos(incidence)."""
    n = len(rays.time_s)
    o, d = rays.origin_m, rays.direction
    t = ground_hit(o, d)
    semantic = np.full(n, GROUND, np.uint8)
    instance = np.full(n, -1, np.int32)
    reflectivity = np.full(n, GRASS_REFLECTIVITY)
    cos_incidence = np.abs(d[:, 2])  # the ground's normal is +z

    # Poses at each ray's time slice, and the bounding spheres of everything but the ground:
    # per slice, the H bodies, the ball, then the static objects.
    slice_of_ray = np.floor((rays.time_s - frame_start_s) / SLICE_S).astype(np.int64)
    slice_of_ray -= slice_of_ray.min(initial=0)
    num_slices = int(slice_of_ray.max(initial=-1)) + 1
    slice_times = np.clip(frame_start_s + (np.arange(num_slices) + 0.5) * SLICE_S, world.clip.time_s[0], world.clip.time_s[-1])
    keypoints, ball = interpolate_clip(world.clip, slice_times)
    num_humanoids = world.clip.num_humanoids
    parts = world.num_parts
    body_centres = keypoints[:, :, KEYPOINT_INDEX["middle"]]
    statics = world.static_spheres
    centres = np.concatenate(
        [body_centres, ball[:, None], np.broadcast_to(statics[:, :3], (num_slices, len(statics), 3))],
        axis=1,
    )
    radius = np.concatenate(
        [np.broadcast_to(world.body_radius, (num_slices, num_humanoids)), np.full((num_slices, 1), BALL_RADIUS_M), np.broadcast_to(statics[:, 3], (num_slices, len(statics)))],
        axis=1,
    )
    ray, sphere = sphere_candidates(o, d, rays.sensor, centres, radius, slice_of_ray, t)
    kind = sphere % centres.shape[1]

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

    # Painted lines on the ground.
    on_ground = np.nonzero((semantic == GROUND) & np.isfinite(t))[0]
    ground_xy = o[on_ground, :2] + t[on_ground, None] * d[on_ground, :2]
    idx = on_ground[on_line(ground_xy[:, 0], ground_xy[:, 1])]
    semantic[idx] = LINE
    reflectivity[idx] = LINE_REFLECTIVITY

    # The ball.
    pair = kind == num_humanoids
    ball_ray = ray[pair]
    ball_centre = ball[slice_of_ray[ball_ray]]
    ball_t = sphere_hit(o[ball_ray], d[ball_ray], ball_centre, BALL_RADIUS_M)
    hit = ball_t < t[ball_ray]
    idx = ball_ray[hit]
    t[idx] = ball_t[hit]
    semantic[idx] = BALL
    instance[idx] = BALL_INSTANCE_ID
    reflectivity[idx] = BALL_REFLECTIVITY
    cos_incidence[idx] = _cos_incidence(o[idx] + ball_t[hit, None] * d[idx] - ball_centre[hit], d[idx])

    # The humanoids: each candidate ray is cast at every part of the posed body (posed only if
    # some ray may reach it).
    pair = kind < num_humanoids
    if pair.any():
        instances, posed = np.unique(sphere[pair] // centres.shape[1] * num_humanoids + kind[pair], return_inverse=True)
        rotation, origin = part_frames(keypoints.reshape(-1, 12, 3)[instances])
        posed = np.repeat(posed, parts)
        part = np.tile(np.arange(parts), pair.sum())
        humanoid = np.repeat(kind[pair], parts)
        hits = world.parts.cast(o, d, np.repeat(ray[pair], parts), part * num_humanoids + humanoid, rotation[posed, part], origin[posed, part], t)
        best = argmin_per_group(n, hits.ray, hits.t_m)
        got = np.nonzero(best >= 0)[0]
        k = best[got]
        hit_humanoid = humanoid[hits.pair[k]]
        t[got] = hits.t_m[k]
        semantic[got] = world.semantic[hit_humanoid]
        instance[got] = world.clip.track_id[hit_humanoid]
        reflectivity[got] = world.face_reflectivity[hits.face[k]]
        cos_incidence[got] = _cos_incidence(hits.normal[k], d[got])
    return {"t": t, "semantic": semantic, "instance": instance, "reflectivity": reflectivity, "cos_incidence": cos_incidence}


def render_frame(world: World, rays: Rays, frame_start_s: float, noise: NoiseConfig, rng: np.random.Generator) -> ScanFrame:
    """Cast a sweep's shots, keep each shot's nearest return in range, and apply the noise model."""
    expanded, shot_of = expand_subrays(rays, noise)
    hit = cast(world, expanded, frame_start_s, rng)
    shots = len(rays.time_s)
    finite = np.nonzero(np.isfinite(hit["t"]))[0]
    if len(shot_of) == shots:  # one ray per shot
        returned = k = finite
    else:  # the nearest of each shot's sub-rays
        best = argmin_per_group(shots, shot_of[finite], hit["t"][finite])
        returned = np.nonzero(best >= 0)[0]
        k = finite[best[returned]]
    t = hit["t"][k]
    reflectivity, cos_incidence = hit["reflectivity"][k], hit["cos_incidence"][k]
    in_range = (t >= noise.min_range_m) & (t <= max_range_m(reflectivity, cos_incidence, noise))
    returned, k, t = returned[in_range], k[in_range], t[in_range]
    missed = shots - len(returned)
    if noise.enabled and noise.dropout > 0:
        kept = rng.random(len(returned)) >= noise.dropout
        returned, k, t = returned[kept], k[kept], t[kept]
    dropped = shots - missed - len(returned)
    if noise.enabled and noise.range_sigma_m > 0:
        t = t + rng.normal(0.0, noise.range_sigma_m, len(t))
    direction = jitter_directions(rays.direction[returned], noise, rng)
    points = rays.origin_m[returned] + t[:, None] * direction
    return ScanFrame(
        points_m=points.astype(np.float32),
        intensity=intensity(hit["reflectivity"][k], hit["cos_incidence"][k]),
        time_offset_s=(rays.time_s[returned] - frame_start_s).astype(np.float32),
        sensor=rays.sensor[returned],
        head=rays.head[returned],
        instance_id=hit["instance"][k],
        semantic=hit["semantic"][k],
        shots=shots,
        dropped=dropped,
        missed=missed,
    )
