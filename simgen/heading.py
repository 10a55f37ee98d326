"""Which way a humanoid faces, from its 12 keypoints (pitch frame, see simgen.skeleton).

The heading is the horizontal perpendicular of the left-right shoulder line (the paper's
definition). Its sign needs no vote: the keypoints are labelled left and right, so
``forward = left x up`` (a person facing +x has their left at +y). The engine only mirrors the
right team by a rotation of 180 degrees about z (``Vector3::Mirror`` negates x and y), which
keeps that handedness. On the engine's captured clip the knees, where bent, bend towards this
front in over 99% of skeletons, and running players move towards it (tests/test_labels.py).

When the shoulder line is (nearly) vertical or its two ends coincide, the heading falls back,
in order, to the hips line (same rule), to the horizontal spine direction middle -> neck
(a player lying on their side faces where their head is), to the horizontal velocity, and
finally to +x (yaw 0). `Heading.source` says which one was used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from simgen.skeleton import KEYPOINT_INDEX, NUM_KEYPOINTS

SHOULDERS, HIPS, SPINE, VELOCITY, DEFAULT = range(5)
SOURCE_NAMES = ("shoulders", "hips", "spine", "velocity", "default")
#: A line (shoulders, hips) or the spine shorter than this seen from above gives no heading.
MIN_HORIZONTAL_M = 0.05
#: Slower than this, the velocity gives no heading.
MIN_SPEED_MPS = 0.1

_I = KEYPOINT_INDEX
_LEFT = [_I["left_shoulder"], _I["left_thigh"]]
_RIGHT = [_I["right_shoulder"], _I["right_thigh"]]
# Least usable length per source; the default always serves.
_MINIMUM = np.array([MIN_HORIZONTAL_M, MIN_HORIZONTAL_M, MIN_HORIZONTAL_M, MIN_SPEED_MPS, 0.0])


@dataclass(frozen=True)
class Heading:
    """Per humanoid: the unit horizontal forward vector and where it came from."""

    forward: NDArray[np.float64]  # (H, 3), z = 0, unit length
    yaw_rad: NDArray[np.float64]  # (H,), counter-clockwise from +x, in (-pi, pi]
    source: NDArray[np.int8]  # (H,), SHOULDERS, HIPS, SPINE, VELOCITY or DEFAULT


def as_keypoints(keypoints: ArrayLike) -> NDArray[np.float64]:
    """Keypoints as a float64 (H, 12, 3) array; ValueError on another shape."""
    kp = np.asarray(keypoints, dtype=np.float64)
    if kp.ndim != 3 or kp.shape[1:] != (NUM_KEYPOINTS, 3):
        raise ValueError(f"keypoints must have shape (H, {NUM_KEYPOINTS}, 3), got {kp.shape}")
    return kp


def wrap_angle(angle_rad: ArrayLike) -> NDArray[np.float64]:
    """Angles wrapped to (-pi, pi]."""
    wrapped = np.remainder(np.asarray(angle_rad, dtype=np.float64) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped <= -np.pi, np.pi, wrapped)


def heading(keypoints: ArrayLike, velocity_mps: ArrayLike | None = None) -> Heading:
    """Heading of each humanoid (H, 12, 3) with optional velocity (H, 3) for the fallback."""
    kp = as_keypoints(keypoints)
    n = len(kp)
    candidates = np.zeros((n, len(SOURCE_NAMES), 3))  # horizontal, in the order of the codes
    lines = kp[:, _LEFT] - kp[:, _RIGHT]  # (H, 2, 3): shoulders, hips, pointing left
    candidates[:, :2, 0], candidates[:, :2, 1] = lines[..., 1], -lines[..., 0]  # left x up
    candidates[:, SPINE, :2] = kp[:, _I["neck"], :2] - kp[:, _I["middle"], :2]
    if velocity_mps is not None:
        candidates[:, VELOCITY, :2] = np.asarray(velocity_mps, dtype=np.float64).reshape(n, 3)[:, :2]
    candidates[:, DEFAULT, 0] = 1.0
    length = np.sqrt(np.einsum("hki,hki->hk", candidates, candidates))
    source = np.argmax(length >= _MINIMUM, axis=1).astype(np.int8)
    rows = np.arange(n)
    forward = candidates[rows, source] / length[rows, source, None]
    yaw = wrap_angle(np.arctan2(forward[:, 1], forward[:, 0]))
    return Heading(forward=forward, yaw_rad=yaw, source=source)
