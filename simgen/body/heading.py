"""Which way a humanoid faces, from its 12 keypoints (pitch frame, see simgen.vocab).

The heading is the horizontal perpendicular of the left-right shoulder line (the paper's
definition). Its sign needs no vote: the keypoints are labelled left and right, so
``forward = left x up`` (a person facing +x has their left at +y). The engine only mirrors the
right team by a rotation of 180 degrees about z (``Vector3::Mirror`` negates x and y), which
keeps that handedness. On the engine's captured clip the knees, where bent, bend towards this
front in over 99% of skeletons, and running players move towards it (tests/test_labels.py).

When the shoulder line is (nearly) vertical or its two ends coincide, the heading falls back,
in order, to the hips line (same rule), to the horizontal spine direction middle -> neck
(a player lying on their side faces where their head is), to the horizontal velocity, and
finally to +x (yaw 0). `Heading.source` says which one was used. The rule is a compiled
per-humanoid kernel, `forward_and_source`, which simgen.body.mesh's compiled rig calls too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from simgen.vocab import KEYPOINT_INDEX, NUM_KEYPOINTS

SHOULDERS, HIPS, SPINE, VELOCITY, DEFAULT = range(5)
#: A line (shoulders, hips) or the spine shorter than this seen from above gives no heading.
MIN_HORIZONTAL_M = 0.05
#: Slower than this, the velocity gives no heading.
MIN_SPEED_MPS = 0.1

_MIDDLE, _NECK = KEYPOINT_INDEX["middle"], KEYPOINT_INDEX["neck"]
_LEFT_SHOULDER, _RIGHT_SHOULDER = KEYPOINT_INDEX["left_shoulder"], KEYPOINT_INDEX["right_shoulder"]
_LEFT_HIP, _RIGHT_HIP = KEYPOINT_INDEX["left_thigh"], KEYPOINT_INDEX["right_thigh"]


@dataclass(frozen=True)
class Heading:
    """Per humanoid: the unit horizontal forward vector and where it came from."""

    forward: NDArray[np.float64]  # (H, 3), z = 0, unit length
    yaw_rad: NDArray[np.float64]  # (H,), counter-clockwise from +x, in (-pi, pi]
    source: NDArray[np.int8]  # (H,), SHOULDERS, HIPS, SPINE, VELOCITY or DEFAULT


def as_keypoints(keypoints: ArrayLike) -> NDArray[np.float64]:
    """Keypoints as a C-contiguous float64 (H, 12, 3) array; ValueError on another shape."""
    kp = np.asarray(keypoints, dtype=np.float64)
    if kp.ndim != 3 or kp.shape[1:] != (NUM_KEYPOINTS, 3):
        raise ValueError(f"keypoints must have shape (H, {NUM_KEYPOINTS}, 3), got {kp.shape}")
    return np.ascontiguousarray(kp)


def wrap_angle(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Angles wrapped to (-pi, pi]."""
    wrapped = np.remainder(np.asarray(angle_rad, dtype=np.float64) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped <= -np.pi, np.pi, wrapped)


@numba.njit(cache=True)
def _left_x_up(kp: NDArray[np.float64], left: int, right: int) -> tuple[float, float]:
    """(x, y) of the line from keypoint right to keypoint left, crossed with up."""
    return kp[left, 1] - kp[right, 1], -(kp[left, 0] - kp[right, 0])


@numba.njit(cache=True)
def forward_and_source(
    kp: NDArray[np.float64], velocity_x_mps: float, velocity_y_mps: float
) -> tuple[float, float, int]:
    """Unit horizontal forward (x, y) of one humanoid's keypoints (12, 3), metres, and its source
    code: the first of SHOULDERS, HIPS, SPINE, VELOCITY, DEFAULT long (or fast) enough."""
    candidates = (  # (x, y, least usable length), in the order of the source codes
        _left_x_up(kp, _LEFT_SHOULDER, _RIGHT_SHOULDER) + (MIN_HORIZONTAL_M,),
        _left_x_up(kp, _LEFT_HIP, _RIGHT_HIP) + (MIN_HORIZONTAL_M,),
        (kp[_NECK, 0] - kp[_MIDDLE, 0], kp[_NECK, 1] - kp[_MIDDLE, 1], MIN_HORIZONTAL_M),
        (velocity_x_mps, velocity_y_mps, MIN_SPEED_MPS),
    )
    for source in range(len(candidates)):
        x, y, minimum = candidates[source]
        length = np.sqrt(x * x + y * y)
        if length >= minimum:
            return x / length, y / length, source
    return 1.0, 0.0, DEFAULT


@numba.njit(cache=True)
def _forwards_and_sources(
    kp: NDArray[np.float64], velocity_mps: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """`forward_and_source` of humanoids (H, 12, 3) with velocities (H, 3): forward (H, 3), source (H,)."""
    forward = np.zeros((len(kp), 3))
    source = np.empty(len(kp), np.int8)
    for h in range(len(kp)):
        forward[h, 0], forward[h, 1], source[h] = forward_and_source(kp[h], velocity_mps[h, 0], velocity_mps[h, 1])
    return forward, source


def heading(keypoints: ArrayLike, velocity_mps: ArrayLike | None = None) -> Heading:
    """Heading of each humanoid (H, 12, 3) with optional velocity (H, 3) for the fallback."""
    kp = as_keypoints(keypoints)
    if velocity_mps is None:
        velocity = np.zeros((len(kp), 3))  # too slow to serve
    else:
        velocity = np.ascontiguousarray(velocity_mps, dtype=np.float64).reshape(len(kp), 3)
    forward, source = _forwards_and_sources(kp, velocity)
    yaw = wrap_angle(np.arctan2(forward[:, 1], forward[:, 0]))
    return Heading(forward=forward, yaw_rad=yaw, source=source)
