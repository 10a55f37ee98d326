"""Oriented 3D boxes of humanoids from their keypoints: the detector's labels.

Box convention (as train/geometry.py): 7 floats (x, y, z, length, width, height, yaw), metres
and radians; (x, y, z) is the centre, length runs along the heading, width across it, height
along z, yaw turns the heading counter-clockwise from +x, in (-pi, pi].

The heading is simgen.body.heading's: the perpendicular of the shoulder line, facing forward, with
its documented fallbacks (hips line, spine, velocity, +x). In the heading frame the box spans
the 12 keypoints and the body's volume, taken from the body model itself (simgen.body.mesh's
`body_extent`, exact for its parts' ellipsoids) rather than from fixed margins, so the body
mesh lies inside and the box is tight around it, in any pose and under any fallback heading.
(Fixed margins around the keypoints would have to reach 0.45 m, the hands, beyond the
elbows; scripts/measure_box_margins.py measures that reach and the boxes' slack, under 1 cm.)
Vertically the box runs from the ground (z = 0), or from the lowest point of the body when
that is `AIRBORNE_M` or more above the ground (a jump), to the highest point of the body.

`labels.size: track` draws every box of a humanoid with one size, the medians of its enclosing
boxes' length, width and height over the clip (`track_sizes`, `with_track_sizes`): the centre stays
the enclosing box's on the pitch plane, and the box keeps its bottom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from simgen.body.heading import as_keypoints, heading
from simgen.body.mesh import body_extent
from simgen.motion.clip import MotionClip
from simgen.motion.interpolate import interpolate_clip, segment_index
from simgen.vocab import KEYPOINT_INDEX

FACE_NAMES = ("front", "back", "left", "right", "top", "bottom")
#: A body whose lowest point is closer to the ground stands on it: the engine's ankle heights
#: vary by a few centimetres, and a box bottom should not jitter with them.
AIRBORNE_M = 0.05
VELOCITY_DT_S = 0.05  # half-width of the central difference for label velocities


@dataclass(frozen=True)
class Boxes:
    """Oriented boxes of H humanoids."""

    centre_m: NDArray[np.float64]  # (H, 3) box centre, pitch frame
    size_m: NDArray[np.float64]  # (H, 3) length (along the heading), width, height
    yaw_rad: NDArray[np.float64]  # (H,) heading, counter-clockwise from +x, in (-pi, pi]

    @property
    def array(self) -> NDArray[np.float64]:
        """(H, 7): x, y, z, length, width, height, yaw."""
        return np.concatenate([self.centre_m, self.size_m, self.yaw_rad[:, None]], axis=1)


def _axes(yaw_rad: NDArray[np.float64]) -> NDArray[np.float64]:
    """(H, 3, 3) rows: heading, its left, up."""
    cos, sin = np.cos(yaw_rad), np.sin(yaw_rad)
    zero, one = np.zeros_like(cos), np.ones_like(cos)
    return np.stack(
        [np.stack([cos, sin, zero], 1), np.stack([-sin, cos, zero], 1), np.stack([zero, zero, one], 1)], 1
    )


def boxes_from_keypoints(keypoints: ArrayLike, velocity_mps: ArrayLike | None = None) -> Boxes:
    """Boxes of humanoids (H, 12, 3), metres; velocity (H, 3) in m/s serves the heading fallback."""
    kp = as_keypoints(keypoints)
    facing = heading(kp, velocity_mps)
    axes = _axes(facing.yaw_rad)
    low, high = body_extent(kp, axes)
    local = np.einsum("hni,hki->hnk", kp, axes)
    low, high = np.minimum(low, local.min(axis=1)), np.maximum(high, local.max(axis=1))
    low[:, 2] = np.where(low[:, 2] < AIRBORNE_M, 0.0, low[:, 2])
    centre = np.einsum("hk,hki->hi", 0.5 * (low + high), axes)
    return Boxes(centre_m=centre, size_m=high - low, yaw_rad=facing.yaw_rad)


def box_frame(points: ArrayLike, boxes: Boxes) -> NDArray[np.float64]:
    """Points (H, N, 3) in their box's frame: from its centre, along its heading, left, up; metres."""
    offset = np.asarray(points, dtype=np.float64) - boxes.centre_m[:, None]
    return np.einsum("hni,hki->hnk", offset, _axes(boxes.yaw_rad))


def overhang(points: ArrayLike, boxes: Boxes) -> NDArray[np.float64]:
    """(H, 6): how far points (H, N, 3) reach beyond each face of their box (FACE_NAMES); metres.

    Negative where every point stays inside that face.
    """
    local = box_frame(points, boxes)
    half = 0.5 * boxes.size_m
    return np.concatenate([local.max(axis=1) - half, -half - local.min(axis=1)], axis=1)[
        :, [0, 3, 1, 4, 2, 5]
    ]


@dataclass(frozen=True)
class FrameLabels:
    """Labels of every humanoid in one frame (zero-point boxes are kept; `num_points` says so)."""

    boxes: NDArray[np.float32]  # (H, 7) x, y, z, length, width, height, yaw; metres, radians
    track_id: NDArray[np.int32]  # (H,)
    team: NDArray[np.str_]  # (H,)
    role: NDArray[np.str_]  # (H,)
    velocity_mps: NDArray[np.float32]  # (H, 3) of `middle`
    keypoints_m: NDArray[np.float32]  # (H, 12, 3)
    num_points: NDArray[np.int32]  # (H,) points of the frame hit on this humanoid
    #: (H,) the engine placed this humanoid between the previous frame's label time and the end of this
    #: frame's sweep: its box may jump from the previous frame's, and its points may lie at both places
    discontinuity: NDArray[np.bool_]


def frame_labels(
    boxes: NDArray, keypoints: NDArray, velocity_mps: NDArray, track_id: NDArray, team: NDArray, role: NDArray,
    point_instance: NDArray, discontinuity: NDArray,
) -> FrameLabels:
    """Labels of humanoids from their boxes (H, 7) (`boxes_from_keypoints`), keypoints (H, 12, 3),
    velocities and placement flags (H,) at the label time, with the number of the frame's points
    (instance ids) each got."""
    ids, counts = np.unique(point_instance[point_instance >= 0], return_counts=True)
    num_points = np.zeros(len(track_id), np.int32)
    found = np.isin(track_id, ids)
    num_points[found] = counts[np.searchsorted(ids, track_id[found])]
    return FrameLabels(
        boxes=np.asarray(boxes, np.float32),
        track_id=np.asarray(track_id, np.int32),
        team=np.asarray(team),
        role=np.asarray(role),
        velocity_mps=np.asarray(velocity_mps, np.float32),
        keypoints_m=np.asarray(keypoints, np.float32),
        num_points=num_points,
        discontinuity=np.asarray(discontinuity, bool),
    )


def label_poses(clip: MotionClip, label_times_s: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Keypoints (F, H, 12, 3), velocities of `middle` (F, H, 3) in m/s and boxes (F, H, 7) at F label times (s).

    Velocities are central differences over +-VELOCITY_DT_S within the label time's segment of the
    humanoid's motion: one-sided next to a placement, zero between two placements closer than that.
    """
    times = np.clip(
        label_times_s[:, None] + np.array([-VELOCITY_DT_S, 0.0, VELOCITY_DT_S]), clip.time_s[0], clip.time_s[-1]
    )
    keypoints, _ = interpolate_clip(clip, times.reshape(-1))
    keypoints = keypoints.reshape(len(times), 3, clip.num_humanoids, 12, 3)
    segment = segment_index(clip, times.reshape(-1)).reshape(len(times), 3, clip.num_humanoids)
    first = np.where(segment[:, 0] == segment[:, 1], 0, 1)[:, None, :, None]  # (F, 1, H, 1): -dt or the label time
    last = np.where(segment[:, 2] == segment[:, 1], 2, 1)[:, None, :, None]  # +dt or the label time
    middle = keypoints[:, :, :, KEYPOINT_INDEX["middle"]]  # (F, 3, H, 3)
    span = np.take_along_axis(times[:, :, None, None], last, 1) - np.take_along_axis(times[:, :, None, None], first, 1)
    moved = np.take_along_axis(middle, last, 1) - np.take_along_axis(middle, first, 1)
    velocity = np.divide(moved, span, out=np.zeros_like(moved), where=span > 0)[:, 0]
    boxes = boxes_from_keypoints(keypoints[:, 1].reshape(-1, 12, 3), velocity.reshape(-1, 3)).array
    return keypoints[:, 1], velocity, boxes.reshape(len(times), clip.num_humanoids, 7)


def placed_between(clip: MotionClip, since_s: NDArray, until_s: NDArray) -> NDArray[np.bool_]:
    """(F, H): whether the engine placed each humanoid in (since, until] (s), for F such spans; spans
    reaching outside the clip are cut to it. With `since` the previous frame's label time and `until`
    the end of the frame's sweep, this is `FrameLabels.discontinuity`."""
    first, last = clip.time_s[0], clip.time_s[-1]
    return segment_index(clip, np.clip(since_s, first, last)) != segment_index(clip, np.clip(until_s, first, last))


TRACK_SIZE_CHUNK = 2000  # label times posed at once by `track_sizes` (a whole match has 54,000)


def track_sizes(clip: MotionClip, label_times_s: NDArray) -> NDArray[np.float64]:
    """(H, 3) each humanoid's median length, width and height (m) over its enclosing boxes at `label_times_s`."""
    sizes = np.empty((len(label_times_s), clip.num_humanoids, 3), np.float64)
    for start in range(0, len(label_times_s), TRACK_SIZE_CHUNK):
        stop = start + TRACK_SIZE_CHUNK
        sizes[start:stop] = label_poses(clip, np.asarray(label_times_s[start:stop], np.float64))[2][..., 3:6]
    return np.median(sizes, axis=0)


def with_track_sizes(boxes: NDArray, sizes: NDArray) -> NDArray[np.float64]:
    """Boxes (..., H, 7) drawn with the humanoids' sizes (H, 3): the same centre on the pitch plane and bottom."""
    out = np.array(boxes, np.float64, copy=True)
    bottom = out[..., 2] - out[..., 5] / 2
    out[..., 3:6] = sizes
    out[..., 2] = bottom + sizes[..., 2] / 2
    return out
