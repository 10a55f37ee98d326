"""Closed triangle meshes of humanoids, posed from their 12 keypoints (numpy in, numpy out).

Each body part is a tapered elliptic capsule: two half-ellipsoid caps, one per end, joined by
a band. Its template (unit sphere split at the equator, band rings at fixed fractions) is
built once; each of its vertices is carried by the affine frame of one end, or by a fixed
blend of both frames for band rings. Posing is then a single sparse matrix product of that
skinning matrix with the 2 x 14 end frames of every humanoid, vectorised over humanoids; the
end frames come from the keypoints by a compiled (numba) loop over humanoids, `_rig`.

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
ankle joint, pointing forward (the heading of simgen.body.heading), flat on the ground while the
ankle is low and square to the shin once it is lifted.

Every part is a closed, consistently wound (outward) mesh; parts overlap at the joints,
which is fine for ray casting. Each face carries a garment (skin, shirt, shorts, socks,
boots), and with the humanoid's team a material of `MATERIALS`. `body_extent` gives the
body's exact reach along any direction without building the mesh (for the label boxes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike, NDArray

from simgen.body.heading import as_keypoints, forward_and_source
from simgen.vocab import KEYPOINT_INDEX, TEAM_NAMES

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
_NUM_PARTS = len(_PARTS)
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


_SHOULDER, _ELBOW, _HIP, _KNEE, _ANKLE = range(5)  # rows of _JOINTS
_JOINTS = np.array(  # keypoint index of each joint, (joint, side: left, right)
    [
        [KEYPOINT_INDEX[f"{side}_{joint}"] for side in ("left", "right")]
        for joint in ("shoulder", "elbow", "thigh", "knee", "ankle")
    ]
)
_MIDDLE, _NECK = KEYPOINT_INDEX["middle"], KEYPOINT_INDEX["neck"]
_PELVIS, _CHEST, _NECK_PART, _HEAD = (PART_NAMES.index(name) for name in ("pelvis", "chest", "neck", "head"))
# Left part of each pair; the right one follows it.
_UPPER_ARM, _FOREARM, _THIGH, _SHIN, _FOOT = (
    PART_NAMES.index(f"left_{name}") for name in ("upper_arm", "forearm", "thigh", "shin", "foot")
)
_COS_FLEXION, _SIN_FLEXION = float(np.cos(ELBOW_FLEXION_RAD)), float(np.sin(ELBOW_FLEXION_RAD))

_Vector = tuple[float, float, float]


@numba.njit(cache=True)
def _add(a: _Vector, b: _Vector) -> _Vector:
    return a[0] + b[0], a[1] + b[1], a[2] + b[2]


@numba.njit(cache=True)
def _sub(a: _Vector, b: _Vector) -> _Vector:
    return a[0] - b[0], a[1] - b[1], a[2] - b[2]


@numba.njit(cache=True)
def _scale(factor: float, a: _Vector) -> _Vector:
    return factor * a[0], factor * a[1], factor * a[2]


@numba.njit(cache=True)
def _dot(a: _Vector, b: _Vector) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True)
def _cross(a: _Vector, b: _Vector) -> _Vector:
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@numba.njit(cache=True)
def _length(a: _Vector) -> float:
    return np.sqrt(_dot(a, a))


@numba.njit(cache=True)
def _divide(a: _Vector, divisor: float) -> _Vector:
    """a / divisor, as a times 1 / divisor (one division instead of three)."""
    inverse = 1.0 / divisor
    return a[0] * inverse, a[1] * inverse, a[2] * inverse


@numba.njit(cache=True)
def _unit(a: _Vector) -> _Vector:
    """a normalised; a / _EPS where it is no longer than _EPS."""
    length = _length(a)
    return _divide(a, _EPS if length <= _EPS else length)


@numba.njit(cache=True)
def _unit_or(a: _Vector, fallback: _Vector) -> _Vector:
    """a normalised, or the fallback `_unit` where a is no longer than _EPS."""
    length = _length(a)
    return _unit(fallback) if length <= _EPS else _divide(a, length)


@numba.njit(cache=True)
def _across(a: _Vector, axis: _Vector) -> _Vector:
    """a made perpendicular to the unit axis."""
    return _sub(a, _scale(_dot(a, axis), axis))


@numba.njit(cache=True)
def _unit_across(a: _Vector, fallback: _Vector, axis: _Vector) -> _Vector:
    """a made perpendicular to the unit axis and normalised; the fallback so where a is parallel."""
    return _unit_or(_across(a, axis), _across(fallback, axis))


@numba.njit(cache=True)
def _unit_across_either(a: _Vector, fallback: _Vector, last: _Vector, axis: _Vector) -> _Vector:
    """As `_unit_across`, with a second fallback, last."""
    across = _across(a, axis)
    length = _length(across)
    return _unit_across(fallback, last, axis) if length <= _EPS else _divide(across, length)


@numba.njit(cache=True)
def _keypoint(kp: NDArray[np.float64], index: int) -> _Vector:
    return kp[index, 0], kp[index, 1], kp[index, 2]


@numba.njit(cache=True)
def _put_part(
    out: NDArray[np.float64], part: int, end0: _Vector, end1: _Vector, along: _Vector, lateral: _Vector,
    lateral_fallback: _Vector,
) -> None:
    """Writes the part's frames (2, 4, 3) into out: the unit axis along it (end 0 -> end 1), the
    unit lateral axis across it (lateral, else lateral_fallback), the second across axis, the
    centres end0 and end1 of its caps."""
    lateral_unit = _unit_across(lateral, lateral_fallback, along)
    rows = (lateral_unit, _cross(along, lateral_unit), along)
    for end, centre in ((0, end0), (1, end1)):
        for row in range(3):
            for i in range(3):
                out[part, end, row, i] = rows[row][i]
        for i in range(3):
            out[part, end, 3, i] = centre[i]


@numba.njit(cache=True)
def _rig_one(kp: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """Writes `_rig` of one humanoid's keypoints (12, 3) into out (P, 2, 4, 3)."""
    forward_x, forward_y, _ = forward_and_source(kp, 0.0, 0.0)  # simgen.body.heading's, with no velocity
    forward, left, z = (forward_x, forward_y, 0.0), (-forward_y, forward_x, 0.0), (0.0, 0.0, 1.0)
    middle, neck = _keypoint(kp, _MIDDLE), _keypoint(kp, _NECK)
    up = _unit_or(_sub(neck, middle), z)
    down = (-up[0], -up[1], -up[2])
    for side in range(2):
        shoulder, elbow = _keypoint(kp, _JOINTS[_SHOULDER, side]), _keypoint(kp, _JOINTS[_ELBOW, side])
        hip, knee = _keypoint(kp, _JOINTS[_HIP, side]), _keypoint(kp, _JOINTS[_KNEE, side])
        ankle = _keypoint(kp, _JOINTS[_ANKLE, side])
        upper_arm, shin = _unit_or(_sub(elbow, shoulder), down), _unit_or(_sub(ankle, knee), down)
        # The forearm hangs from the elbow nearer the body's mid-plane than the upper arm does, bent
        # towards the front (else up, else left).
        sideways = _scale(_dot(upper_arm, left), left)
        straight = _unit(_sub(upper_arm, _scale(1.0 - _FOREARM_SIDEWAYS, sideways)))
        bend = _unit_across_either(forward, up, left, straight)
        forearm = _add(_scale(_COS_FLEXION, straight), _scale(_SIN_FLEXION, bend))
        # The foot points forward, else up, else left, square to the shin, and lies flat while the
        # ankle is near the ground.
        square = _unit_across_either(forward, z, left, shin)
        free = (ankle[2] - _FOOT_FLAT_BELOW_M) / (_FOOT_FREE_ABOVE_M - _FOOT_FLAT_BELOW_M)
        if free < 0.0:
            free = 0.0
        elif free > 1.0:
            free = 1.0
        foot = _unit_or(_add(_scale(1.0 - free, forward), _scale(free, square)), square)
        sole = _unit_across(shin, (0.0, 0.0, -1.0), foot)  # from the ankle towards the sole
        heel = _add(_add(ankle, _scale(_HEEL_CENTRE_M[0], foot)), _scale(_HEEL_CENTRE_M[1], sole))
        toe = _add(_add(ankle, _scale(_TOE_CENTRE_M[0], foot)), _scale(_TOE_CENTRE_M[1], sole))
        hand = _add(elbow, _scale(_HAND_CENTRE_M, forearm))
        # Lateral axes: the body's left (the feet: their own), else forward. upper_arm, forearm, shin,
        # foot and up are unit vectors already (up to rounding); only the thigh's axis is normalised.
        _put_part(out, _UPPER_ARM + side, shoulder, elbow, upper_arm, left, forward)
        _put_part(out, _FOREARM + side, elbow, hand, forearm, left, forward)
        _put_part(out, _THIGH + side, hip, knee, _unit_or(_sub(knee, hip), up), left, forward)
        _put_part(out, _SHIN + side, knee, ankle, shin, left, forward)
        _put_part(out, _FOOT + side, heel, toe, foot, _cross(foot, sole), forward)
    # The pelvis and the chest follow the hips and the shoulders lines, else the body's left.
    left_hip, right_hip = _keypoint(kp, _JOINTS[_HIP, 0]), _keypoint(kp, _JOINTS[_HIP, 1])
    hip_centre = _scale(0.5, _add(left_hip, right_hip))
    pelvis = _unit_or(_sub(middle, hip_centre), up)
    _put_part(out, _PELVIS, hip_centre, middle, pelvis, _sub(left_hip, right_hip), left)
    shoulders = _sub(_keypoint(kp, _JOINTS[_SHOULDER, 0]), _keypoint(kp, _JOINTS[_SHOULDER, 1]))
    _put_part(out, _CHEST, middle, _add(middle, _scale(_CHEST_LENGTH_M, up)), up, shoulders, left)
    neck_low, neck_high = _sub(neck, _scale(_NECK_BELOW_M, up)), _add(neck, _scale(_NECK_ABOVE_M, up))
    _put_part(out, _NECK_PART, neck_low, neck_high, up, left, forward)
    front = _unit_across_either(forward, z, left, up)
    head = _add(_add(neck, _scale(_HEAD_CENTRE_UP_M, up)), _scale(_HEAD_CENTRE_FORWARD_M, front))
    head_low, head_high = _sub(head, _scale(_HEAD_HALF_SPAN_M, up)), _add(head, _scale(_HEAD_HALF_SPAN_M, up))
    _put_part(out, _HEAD, head_low, head_high, up, left, forward)


@numba.njit(cache=True)
def _rig(kp: NDArray[np.float64]) -> NDArray[np.float64]:
    """(H, P, 2, 4, 3): per end of every part of humanoids (H, 12, 3), its unit frame and centre.

    The 4 rows are the unit lateral axis, the second across axis, the axis along the part
    (end 0 -> end 1), and the centre of the end's cap; the template's unit sphere, scaled by
    the part's half-axes, maps through them.
    """
    out = np.empty((len(kp), _NUM_PARTS, 2, 4, 3))
    for h in range(len(kp)):
        _rig_one(kp[h], out[h])
    return out


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
    return _part_frames(as_keypoints(keypoints))


@numba.njit(cache=True)
def _part_frames(kp: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`part_frames` without `_rig`'s (H, P, 2, 4, 3) array: the renderer poses thousands at a time."""
    rotation = np.empty((len(kp), _NUM_PARTS, 3, 3))
    origin = np.empty((len(kp), _NUM_PARTS, 3))
    ends = np.empty((_NUM_PARTS, 2, 4, 3))
    for h in range(len(kp)):
        _rig_one(kp[h], ends)
        for p in range(_NUM_PARTS):
            for a in range(3):
                for b in range(3):
                    rotation[h, p, a, b] = ends[p, 0, b, a]  # the frame's rows are the part's axes
                origin[h, p, a] = ends[p, 0, 3, a]
    return rotation, origin


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


@numba.njit(cache=True)
def _extent_kernel(
    kp: NDArray[np.float64], directions: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`body_extent` of humanoids (H, 12, 3) along directions (H, K, 3)."""
    low, high = np.empty(directions.shape[:2]), np.empty(directions.shape[:2])
    rig = np.empty((_NUM_PARTS, 2, 4, 3))
    for h in range(len(kp)):
        _rig_one(kp[h], rig)
        for k in range(directions.shape[1]):
            d = (directions[h, k, 0], directions[h, k, 1], directions[h, k, 2])
            lowest, highest = np.inf, -np.inf
            for p in range(_NUM_PARTS):
                for end in range(2):
                    centre = rig[p, end, 3, 0] * d[0] + rig[p, end, 3, 1] * d[1] + rig[p, end, 3, 2] * d[2]
                    squared = 0.0  # of the reach: the cap's half-axes projected on d
                    for axis in range(3):
                        projected = (
                            rig[p, end, axis, 0] * d[0] + rig[p, end, axis, 1] * d[1] + rig[p, end, axis, 2] * d[2]
                        ) * _HALF_AXES_M[p, end, axis]
                        squared += projected * projected
                    near, far = centre - np.sqrt(squared), centre + np.sqrt(squared)
                    if near < lowest or np.isnan(near):  # NaN wins, as in np.min
                        lowest = near
                    if far > highest or np.isnan(far):
                        highest = far
            low[h, k], high[h, k] = lowest, highest
    return low, high


def body_extent(
    keypoints: ArrayLike, directions: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(low, high), each (H, K): the range of x . d over the body of humanoids (H, 12, 3), metres.

    For unit directions d (H, K, 3). Exact for the parts' cap ellipsoids, whose convex hulls
    hold the meshes (cap vertices lie on them, band vertices between them), so the mesh
    reaches at most this far, and less by no more than its chord error (under 1 cm).
    """
    kp = as_keypoints(keypoints)
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim != 3 or d.shape[2] != 3:
        raise ValueError(f"directions must have shape (H, K, 3), got {d.shape}")
    return _extent_kernel(kp, np.ascontiguousarray(np.broadcast_to(d, (len(kp),) + d.shape[1:])))
