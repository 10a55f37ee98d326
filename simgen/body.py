"""Closed triangle meshes of humanoids, posed from their 12 keypoints (numpy in, numpy out).

Each body part is a tapered elliptic capsule: two half-ellipsoid caps, one per end, joined by
a band. Its template (unit sphere split at the equator, band rings at fixed fractions) is
built once; each of its vertices is carried by the affine frame of one end, or by a fixed
blend of both frames for band rings. Posing is then a single sparse matrix product of that
skinning matrix with the 2 x 14 end frames of every humanoid, vectorised over humanoids.

Both ends of a part share one orientation and the engine's skeleton is rigid (every bone has
the same length in every frame and player), so each part moves rigidly with its frame
(`part_frames`): the ray caster keeps each part's mesh once, in part coordinates
(`part_templates`), and moves rays instead of meshes.

Parts and sizes (fixed adult half-axes; segment lengths come from the keypoints): pelvis from
the centre of the hip joints to `middle` (rigid with the hips), chest from `middle` 0.48 m up
the spine (rigid with the shoulders, which turn with the spine), both 0.34 m across and
0.22-0.23 m front to back; neck; head, its top 0.26 m above the neck keypoint along the spine (middle ->
neck); upper arms; forearm plus hand, 0.45 m long from the elbow (there is no wrist keypoint):
the upper arm's direction with most of its sideways lean taken out, bent `ELBOW_FLEXION_RAD`
towards the body's front; thighs; shins; feet 0.265 m long, their soles 0.085 m below the
ankle joint, pointing forward (the heading of simgen.heading), flat on the ground while the
ankle is low and square to the shin once it is lifted.

Every part is a closed, consistently wound (outward) mesh; parts overlap at the joints,
which is fine for ray casting. Each face carries a garment (skin, shirt, shorts, socks,
boots), and with the humanoid's team a material of `MATERIALS`. `body_extent` gives the
body's exact reach along any direction without building the mesh (for the label boxes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike, NDArray

from simgen.heading import as_keypoints, heading
from simgen.skeleton import KEYPOINT_INDEX

TEAM_NAMES = ("left", "right", "official")  # as simgen.motion.MotionClip.team
GARMENT_NAMES = ("skin", "shirt", "shorts", "socks", "boots")
SKIN, SHIRT, SHORTS, SOCKS, BOOTS = range(len(GARMENT_NAMES))
ELBOW_FLEXION_RAD = np.deg2rad(40.0)
_EPS = 1e-9


@dataclass(frozen=True)
class Material:
    """A surface seen by the LiDAR: Lambertian reflectivity (albedo) at 905 nm, 0..1."""

    name: str
    reflectivity: float


# Reflectivities at 905 nm (assumptions, from the ranges published for near-infrared
# diffuse reflectance; no measurement of real kits):
# - skin 0.45: skin reflects about 0.35 (dark) to 0.6 (light) at 800-950 nm, where melanin
#   absorbs little (e.g. Anderson & Parrish 1981, "The optics of human skin"); a mid value.
# - left team, a light kit: white polyester reflects about 0.7-0.9 in the near infrared: 0.8.
# - right team, a dark kit: 0.2, a weakly reflecting one. (Dyes that look dark can still
#   reflect much more at 905 nm, as they need only absorb visible light.)
# - officials in black: 0.06, as carbon-black pigmented fabric (a few per cent).
# - boots, black synthetic leather: 0.1.
_KIT_REFLECTIVITY = {"left": 0.8, "right": 0.2, "official": 0.06}  # shirt, shorts and socks
MATERIALS: tuple[Material, ...] = (Material("skin", 0.45), Material("boots", 0.1)) + tuple(
    Material(f"{garment}_{team}", _KIT_REFLECTIVITY[team])
    for team in TEAM_NAMES
    for garment in ("shirt", "shorts", "socks")
)
MATERIAL_NAMES = tuple(m.name for m in MATERIALS)
REFLECTIVITY = np.array([m.reflectivity for m in MATERIALS], dtype=np.float32)
# (team, garment) -> material id
_KIT_MATERIAL = np.array(
    [
        [
            MATERIAL_NAMES.index(f"{g}_{team}" if g in ("shirt", "shorts", "socks") else g)
            for g in GARMENT_NAMES
        ]
        for team in TEAM_NAMES
    ],
    dtype=np.int16,
)


@dataclass(frozen=True)
class _Part:
    name: str
    segments: int  # vertices around
    cap_rings: int  # rings of each cap between its pole and the equator
    cuts: tuple[float, ...]  # band rings, as fractions from end 0 to end 1
    garments: tuple[int, ...]  # from end 0 up to the first cut, between cuts, ... to end 1
    half_axes_m: tuple[
        tuple[float, float, float], tuple[float, float, float]
    ]  # per end: across (lateral), across, along


_PARTS = (
    _Part("pelvis", 10, 2, (), (SHORTS,), ((0.17, 0.11, 0.08), (0.17, 0.11, 0.07))),
    _Part("chest", 10, 2, (), (SHIRT,), ((0.17, 0.11, 0.07), (0.17, 0.115, 0.06))),
    _Part("neck", 6, 1, (), (SKIN,), ((0.055, 0.055, 0.055), (0.055, 0.055, 0.055))),
    _Part("head", 8, 2, (), (SKIN,), ((0.075, 0.095, 0.095), (0.075, 0.095, 0.095))),
    *(
        _Part(f"{side}_upper_arm", 6, 1, (0.5,), (SHIRT, SKIN), ((0.05, 0.05, 0.05), (0.04, 0.04, 0.04)))
        for side in ("left", "right")
    ),
    *(
        _Part(f"{side}_forearm", 6, 1, (), (SKIN,), ((0.04, 0.04, 0.04), (0.022, 0.045, 0.05)))
        for side in ("left", "right")
    ),
    *(
        _Part(f"{side}_thigh", 8, 1, (0.35,), (SHORTS, SKIN), ((0.085, 0.085, 0.085), (0.055, 0.055, 0.055)))
        for side in ("left", "right")
    ),
    *(
        _Part(f"{side}_shin", 6, 1, (0.15,), (SKIN, SOCKS), ((0.055, 0.055, 0.055), (0.04, 0.04, 0.04)))
        for side in ("left", "right")
    ),
    *(
        _Part(f"{side}_foot", 6, 1, (), (BOOTS,), ((0.04, 0.04, 0.045), (0.045, 0.03, 0.04)))
        for side in ("left", "right")
    ),
)
PART_NAMES = tuple(p.name for p in _PARTS)
_HALF_AXES_M = np.array([p.half_axes_m for p in _PARTS])  # (P, 2, 3)

# Placement along the body, metres.
_CHEST_LENGTH_M = 0.48  # middle -> top of the chest, along the spine (the shoulders are 0.483 up it)
_NECK_BELOW_M, _NECK_ABOVE_M = 0.04, 0.09  # neck capsule around the neck keypoint, along the spine
_HEAD_CENTRE_UP_M, _HEAD_CENTRE_FORWARD_M = 0.145, 0.02  # head centre from the neck keypoint
_HEAD_HALF_SPAN_M = 0.02  # head cap centres either side of the head centre, along the spine
_HAND_CENTRE_M = 0.40  # elbow -> centre of the hand cap; its tip is 0.45 m from the elbow
_FOREARM_SIDEWAYS = 0.2  # of the upper arm's sideways lean, kept by the forearm (elbows out, hands in)
# Ankle heights below which the foot lies flat, above which it is square to the shin.
_FOOT_FLAT_BELOW_M, _FOOT_FREE_ABOVE_M = 0.12, 0.25
_HEEL_CENTRE_M = (-0.01, 0.045)  # (forward, down to the sole) from the ankle joint
_TOE_CENTRE_M = (0.17, 0.055)


@dataclass(frozen=True)
class BodyMeshes:
    """Meshes of H humanoids sharing one template topology (per humanoid V vertices, F faces)."""

    vertices_m: NDArray[np.float32]  # (H, V, 3), pitch frame, metres
    faces: NDArray[np.int32]  # (F, 3) indices into one humanoid's vertices, wound outward (CCW)
    part_id: NDArray[np.int16]  # (F,) index into PART_NAMES
    material_id: NDArray[np.int16]  # (H, F) index into MATERIALS / REFLECTIVITY


def _template() -> tuple[scipy.sparse.csr_array, NDArray[np.int32], NDArray[np.int16], NDArray[np.int16]]:
    """Skinning matrix, faces (F, 3), part id (F,) and garment (F,) of all parts.

    The skinning matrix (V, P * 2 * 4) maps the unit frame columns and the origin of both ends
    of every part, (P, 2, 4) rows of 3 coordinates, to the V vertex positions.
    """
    rows, cols, vals, faces, part_id, garment = [], [], [], [], [], []
    count = 0
    for p, part in enumerate(_PARTS):
        n = part.segments
        theta = 2.0 * np.pi * np.arange(n) / n
        polar = np.pi / 2 * np.arange(1, part.cap_rings + 1) / (part.cap_rings + 1)
        # Rings from end 0's pole to end 1's: (z, radius, blend t towards end 1, garment).
        rings = [(-np.cos(a), np.sin(a), 0.0, part.garments[0]) for a in polar]
        rings += [
            (0.0, 1.0, t, g) for t, g in zip((0.0, *part.cuts, 1.0), (*part.garments, part.garments[-1]))
        ]
        rings += [(np.cos(a), np.sin(a), 1.0, part.garments[-1]) for a in polar[::-1]]
        local = [(0.0, 0.0, -1.0, 0.0)]
        for z, radius, t, _ in rings:
            local += [(radius * np.cos(a), radius * np.sin(a), z, t) for a in theta]
        local.append((0.0, 0.0, 1.0, 1.0))
        for v, (x, y, z, t) in enumerate(local):
            for end, weight in ((0, 1.0 - t), (1, t)):
                if weight > 0.0:
                    a, b, c = part.half_axes_m[end]
                    rows += [count + v] * 4
                    cols += [(p * 2 + end) * 4 + j for j in range(4)]
                    vals += [weight * a * x, weight * b * y, weight * c * z, weight]
        ring_start = 1 + n * np.arange(len(rings))
        j, k = np.arange(n), (np.arange(n) + 1) % n
        pole0, pole1 = 0, len(local) - 1
        tris = [np.stack([np.full(n, pole0), ring_start[0] + k, ring_start[0] + j], axis=1)]
        ring_garment = [part.garments[0]]
        for r in range(len(rings) - 1):
            a, b = ring_start[r], ring_start[r + 1]
            tris += [np.stack([a + j, a + k, b + k], axis=1), np.stack([a + j, b + k, b + j], axis=1)]
            ring_garment += [rings[r][3]] * 2  # a ring's garment is that of the strip above it
        tris.append(np.stack([np.full(n, pole1), ring_start[-1] + j, ring_start[-1] + k], axis=1))
        ring_garment.append(part.garments[-1])
        faces += [t + count for t in tris]
        garment += [np.full(n, g) for g in ring_garment]
        part_id.append(np.full(sum(len(t) for t in tris), p))
        count += len(local)
    skinning = scipy.sparse.csr_array((vals, (rows, cols)), shape=(count, len(_PARTS) * 2 * 4))
    return (
        skinning,
        np.concatenate(faces).astype(np.int32),
        np.concatenate(part_id).astype(np.int16),
        np.concatenate(garment).astype(np.int16),
    )


_SKINNING, _FACES, _PART_ID, _GARMENT = _template()
for _array in (_FACES, _PART_ID, _GARMENT):
    _array.flags.writeable = False
NUM_VERTICES, NUM_FACES = _SKINNING.shape[0], len(_FACES)
# Each part owns a contiguous run of vertices and of faces.
_PART_FACE_START = np.searchsorted(_PART_ID, np.arange(len(_PARTS) + 1))
_PART_VERTEX_START = np.append(_FACES[_PART_FACE_START[:-1]].min(axis=1), NUM_VERTICES)


def _first_unit(candidates: NDArray[np.float64]) -> NDArray[np.float64]:
    """(..., 3): the first of candidates (..., K, 3) of non-zero length, normalised."""
    first = candidates[..., 0, :]
    length = np.sqrt(np.einsum("...i,...i->...", first, first))
    out = first / np.maximum(length, _EPS)[..., None]
    degenerate = length <= _EPS
    if candidates.shape[-2] > 1 and degenerate.any():  # rare: fall back only where needed
        out[degenerate] = _first_unit(candidates[degenerate][:, 1:])
    return out


def _first_across(candidates: NDArray[np.float64], axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """(..., 3): the first of candidates (..., K, 3) not parallel to the unit axis (..., 3), made
    perpendicular to it and normalised."""
    lead = np.broadcast_shapes(candidates.shape[:-2], axis.shape[:-1])
    first = candidates[..., 0, :]
    across = first - np.einsum("...i,...i->...", first, axis)[..., None] * axis
    length = np.sqrt(np.einsum("...i,...i->...", across, across))
    out = np.broadcast_to(across / np.maximum(length, _EPS)[..., None], lead + (3,)).copy()
    degenerate = np.broadcast_to(length <= _EPS, lead)
    if candidates.shape[-2] > 1 and degenerate.any():  # rare: fall back only where needed
        rest = np.broadcast_to(candidates, lead + candidates.shape[-2:])[degenerate][:, 1:]
        out[degenerate] = _first_across(rest, np.broadcast_to(axis, lead + (3,))[degenerate])
    return out


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """a x b over the last axis (np.cross costs more on small arrays)."""
    return a[..., [1, 2, 0]] * b[..., [2, 0, 1]] - a[..., [2, 0, 1]] * b[..., [1, 2, 0]]


_FORWARD, _UP, _LEFT, _Z, _DOWN = range(5)  # rows of the per-humanoid basis in _rig
_PAIRS = np.array(
    [
        [KEYPOINT_INDEX[f"{side}_{joint}"] for side in ("left", "right")]
        for joint in ("shoulder", "elbow", "thigh", "knee", "ankle")
    ]
)
_SHOULDER, _ELBOW, _HIP, _KNEE, _ANKLE = range(5)


def _rig(kp: NDArray[np.float64]) -> NDArray[np.float64]:
    """(H, P, 2, 4, 3): per end of every part of humanoids (H, 12, 3), its unit frame and centre.

    The 4 rows are the unit lateral axis, the second across axis, the axis along the part
    (end 0 -> end 1), and the centre of the end's cap; the template's unit sphere, scaled by
    the part's half-axes, maps through them.
    """
    n = len(kp)
    middle, neck = kp[:, KEYPOINT_INDEX["middle"]], kp[:, KEYPOINT_INDEX["neck"]]
    joints = kp[:, _PAIRS]  # (H, 5, 2, 3): shoulders, elbows, hips, knees, ankles; left, right
    basis = np.zeros((n, 5, 3))
    basis[:, _FORWARD] = heading(kp).forward
    basis[:, _LEFT, 0], basis[:, _LEFT, 1] = -basis[:, _FORWARD, 1], basis[:, _FORWARD, 0]
    basis[:, _Z, 2] = 1.0
    basis[:, _UP] = _first_unit(np.stack([neck - middle, basis[:, _Z]], axis=1))
    basis[:, _DOWN] = -basis[:, _UP]
    forward, up, left = basis[:, _FORWARD], basis[:, _UP], basis[:, _LEFT]

    # Upper arms and shins, (H, limb, side, 3).
    limbs = np.empty((n, 2, 2, 2, 3))
    limbs[:, :, :, 0] = joints[:, [_ELBOW, _ANKLE]] - joints[:, [_SHOULDER, _KNEE]]
    limbs[:, :, :, 1] = basis[:, None, None, _DOWN]
    limbs = _first_unit(limbs)
    upper_arm, shin = limbs[:, 0].copy(), limbs[:, 1]
    # The forearms hang from the elbows nearer the body's mid-plane than the upper arms do, bent
    # towards the front (else up, else left). The feet point forward, else up, else left,
    # square to the shins, and lie flat while the ankles are near the ground.
    sideways = np.einsum("hsi,hi->hs", upper_arm, left)[..., None] * left[:, None]
    limbs[:, 0] = _first_unit((upper_arm - (1.0 - _FOREARM_SIDEWAYS) * sideways)[:, :, None])
    across = _first_across(basis[:, [[_FORWARD, _UP, _LEFT], [_FORWARD, _Z, _LEFT]]][:, :, None], limbs)
    forearm = np.cos(ELBOW_FLEXION_RAD) * limbs[:, 0] + np.sin(ELBOW_FLEXION_RAD) * across[:, 0]
    ankles = joints[:, _ANKLE]
    lift = (ankles[..., 2:] - _FOOT_FLAT_BELOW_M) / (_FOOT_FREE_ABOVE_M - _FOOT_FLAT_BELOW_M)
    free = np.clip(lift, 0.0, 1.0)
    feet = np.stack([(1.0 - free) * forward[:, None] + free * across[:, 1], across[:, 1]], axis=2)
    foot = _first_unit(feet)
    sole = np.stack([shin, np.broadcast_to(-basis[:, None, _Z], shin.shape)], axis=2)
    down = _first_across(sole, foot)  # (H, side, 3): from the ankle towards the sole
    heel = ankles + _HEEL_CENTRE_M[0] * foot + _HEEL_CENTRE_M[1] * down
    toe = ankles + _TOE_CENTRE_M[0] * foot + _TOE_CENTRE_M[1] * down
    hand = joints[:, _ELBOW] + _HAND_CENTRE_M * forearm
    head = (
        neck
        + _HEAD_CENTRE_UP_M * up
        + _HEAD_CENTRE_FORWARD_M * _first_across(basis[:, [_FORWARD, _Z, _LEFT]], up)
    )
    shoulder_centre, hip_centre = joints[:, _SHOULDER].mean(axis=1), joints[:, _HIP].mean(axis=1)

    def single(*rows: NDArray[np.float64]) -> NDArray[np.float64]:  # (H, 3) each -> (H, k, 3)
        return np.stack(rows, axis=1)

    # Per part (in PART_NAMES order): end 0, end 1, along, lateral reference at each end.
    p0 = np.concatenate(
        [
            single(hip_centre, middle, neck - _NECK_BELOW_M * up, head - _HEAD_HALF_SPAN_M * up),
            joints[:, _SHOULDER],
            joints[:, _ELBOW],
            joints[:, _HIP],
            joints[:, _KNEE],
            heel,
        ],
        axis=1,
    )
    p1 = np.concatenate(
        [
            single(middle, middle + _CHEST_LENGTH_M * up, neck + _NECK_ABOVE_M * up, head + _HEAD_HALF_SPAN_M * up),
            joints[:, _ELBOW],
            hand,
            joints[:, _KNEE],
            ankles,
            toe,
        ],
        axis=1,
    )
    along = np.empty(p0.shape[:2] + (2, 3))  # (H, P, candidate, 3)
    along[:, :, 0] = np.concatenate(
        [
            single(middle - hip_centre, up, up, up),
            upper_arm,
            forearm,
            joints[:, _KNEE] - joints[:, _HIP],
            shin,
            foot,
        ],
        axis=1,
    )
    along[:, :, 1] = up[:, None]
    along = _first_unit(along)
    # Lateral axes: the body's left (the feet: their own), else forward; the pelvis and the chest
    # follow the hips and the shoulders lines.
    refs = np.empty_like(p0, shape=p0.shape[:2] + (2, 3))
    refs[:, :, 0] = left[:, None]
    refs[:, -2:, 0] = _cross(foot, down)
    refs[:, :, 1] = forward[:, None]
    refs[:, :2, 0] = joints[:, [_HIP, _SHOULDER], 0] - joints[:, [_HIP, _SHOULDER], 1]
    refs[:, :2, 1] = left[:, None]
    affine = np.empty(p0.shape[:2] + (2, 4, 3))
    lateral = _first_across(refs, along)
    affine[:, :, :, :3] = np.stack([lateral, _cross(along, lateral), along], axis=-2)[:, :, None]
    affine[:, :, 0, 3], affine[:, :, 1, 3] = p0, p1
    return affine


def _team_ids(teams: ArrayLike, count: int) -> NDArray[np.intp]:
    names = np.asarray(teams).reshape(-1)
    if len(names) != count:
        raise ValueError(f"got {len(names)} teams for {count} humanoids")
    unknown = set(names.tolist()) - set(TEAM_NAMES)
    if unknown:
        raise ValueError(f"unknown teams {sorted(unknown)}; expected one of {TEAM_NAMES}")
    return np.array([TEAM_NAMES.index(name) for name in names.tolist()], dtype=np.intp)


def body_meshes(keypoints: ArrayLike, teams: ArrayLike) -> BodyMeshes:
    """Meshes of humanoids posed by keypoints (H, 12, 3), metres, with teams (H,) of TEAM_NAMES."""
    kp = as_keypoints(keypoints)
    team = _team_ids(teams, len(kp))
    # (H, P, 2, 4, 3) -> rows (P, 2, 4) as the skinning matrix's columns, columns (H, 3).
    stacked = _rig(kp).transpose(1, 2, 3, 0, 4).reshape(_SKINNING.shape[1], 3 * len(kp))
    vertices = (_SKINNING @ stacked).reshape(NUM_VERTICES, len(kp), 3).transpose(1, 0, 2)
    return BodyMeshes(
        vertices_m=np.ascontiguousarray(vertices, dtype=np.float32),
        faces=_FACES,
        part_id=_PART_ID,
        material_id=_KIT_MATERIAL[team][:, _GARMENT],
    )


def part_frames(keypoints: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rigid frame of every part of humanoids (H, 12, 3): rotation (H, P, 3, 3) from part to pitch
    coordinates, and origin (H, P, 3), metres (the centre of the part's end-0 cap)."""
    frame = _rig(as_keypoints(keypoints))[:, :, 0]
    return np.swapaxes(frame[:, :, :3], -1, -2), frame[:, :, 3]


def part_templates(keypoints: ArrayLike, teams: ArrayLike) -> list[tuple[NDArray, NDArray, NDArray]]:
    """Per part: (vertices (H, V_p, 3) in part coordinates, faces (F_p, 3), material ids (H, F_p)).

    Taken from one pose of each humanoid; valid in every pose, as parts are rigid.
    """
    meshes = body_meshes(keypoints, teams)
    rotation, origin = part_frames(keypoints)
    templates = []
    for p in range(len(_PARTS)):
        v0, v1 = _PART_VERTEX_START[p], _PART_VERTEX_START[p + 1]
        f0, f1 = _PART_FACE_START[p], _PART_FACE_START[p + 1]
        local = np.einsum("hji,hvj->hvi", rotation[:, p], meshes.vertices_m[:, v0:v1] - origin[:, p, None])
        templates.append((local, _FACES[f0:f1] - v0, meshes.material_id[:, f0:f1]))
    return templates


def body_extent(
    keypoints: ArrayLike, directions: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(low, high), each (H, K): the range of x . d over the body of humanoids (H, 12, 3), metres.

    For unit directions d (H, K, 3). Exact for the parts' cap ellipsoids, whose convex hulls
    hold the meshes (cap vertices lie on them, band vertices between them), so the mesh
    reaches at most this far, and less by no more than its chord error (under 1 cm).
    """
    affine = _rig(as_keypoints(keypoints))
    d = np.asarray(directions, dtype=np.float64)
    centre = np.einsum("hpei,hki->hpek", affine[:, :, :, 3], d)
    axes = np.einsum("hpeci,hki->hpeck", affine[:, :, :, :3], d) * _HALF_AXES_M[None, :, :, :, None]
    reach = np.sqrt(np.einsum("hpeck,hpeck->hpek", axes, axes))
    return (centre - reach).min(axis=(1, 2)), (centre + reach).max(axis=(1, 2))
