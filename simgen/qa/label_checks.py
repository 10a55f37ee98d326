"""Label sanity of a clip's frames: boxes on the pitch and of a human size, stored point counts that
match the points, and track ids that neither skip frames nor jump.

Boxes describe the middle of a frame's sweep while each point has its own shot time, so a
humanoid's points are looked for in its box grown by a margin plus its speed x half a frame, or,
where the format keeps point times, in the box of the neighbouring frame on the point's side of the
label time, grown alike: a limb swinging faster than the body can leave the first and be in the
second (a stride lengthens a box by half a metre within a frame). A box
with a `discontinuity` (the engine placed its humanoid for a restart) is a new segment of its track:
its points may lie at both places and its centre may jump, so neither is held against it; a jump
without the flag is still a problem.
`Locate(frame index, box index)` says where a box is stored: (file, row).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from simgen.datasets.formats.base import Locate
from simgen.datasets.frame import Frame
from simgen.datasets.verify import Problem
from simgen.qa.checks import plural
from simgen.qa.tolerances import LabelTolerances
from simgen.scene.pitch import HALF_LENGTH_M, HALF_WIDTH_M

GROUND_SLACK_M = 0.01  # a box bottom may sit this far below z = 0 (float32 text round trips)
SIZE_NAMES = ("length", "width", "height")


def box_problems(frame: Frame, locate: Locate, tol: LabelTolerances) -> list[Problem]:
    """Boxes that are not finite, not human-sized, off the pitch, under the ground or badly turned."""
    problems = []
    for i, (x, y, z, *size, yaw) in enumerate(np.asarray(frame.boxes, np.float64)):
        file, row = locate(frame.index, i)
        if not np.isfinite([x, y, z, *size, yaw]).all():
            problems.append(Problem(file, row, "box has a value that is not finite"))
            continue
        for name, value in zip(SIZE_NAMES, size):
            if not tol.min_box_size_m <= value <= tol.max_box_size_m:
                problems.append(
                    Problem(
                        file, row, f"box {name} {value:z.3f} m outside {tol.min_box_size_m:g}-{tol.max_box_size_m:g} m"
                    )
                )
        if abs(x) > HALF_LENGTH_M + tol.pitch_margin_m or abs(y) > HALF_WIDTH_M + tol.pitch_margin_m:
            problems.append(
                Problem(
                    file, row, f"box centre ({x:z.2f}, {y:z.2f}) m is off the pitch grown by {tol.pitch_margin_m:g} m"
                )
            )
        if z - size[2] / 2 < -GROUND_SLACK_M:
            problems.append(Problem(file, row, f"box bottom at z = {z - size[2] / 2:z.3f} m, under the ground"))
        if not -np.pi - 1e-6 <= yaw <= np.pi + 1e-6:
            problems.append(Problem(file, row, f"yaw {yaw:z.3f} rad outside [-pi, pi]"))
    return problems


def in_box(points: NDArray, box: NDArray, grow_m: float) -> NDArray[np.bool_]:
    """Which points lie in the box grown by `grow_m` across and along the heading, exactly in z."""
    offset = np.asarray(points, np.float64) - box[:3]
    cos, sin = np.cos(box[6]), np.sin(box[6])
    along = offset[:, 0] * cos + offset[:, 1] * sin
    across = -offset[:, 0] * sin + offset[:, 1] * cos
    return (
        (np.abs(along) <= box[3] / 2 + grow_m)
        & (np.abs(across) <= box[4] / 2 + grow_m)
        & (np.abs(offset[:, 2]) <= box[5] / 2 + grow_m)
    )


def _box_of(frame: Frame | None, track: int) -> tuple[NDArray, float] | None:
    """The box (7,) and speed (m/s) of `track` in a neighbouring frame, unless absent or placed there."""
    if frame is None:
        return None
    found = np.flatnonzero(frame.track_id == track)
    if not len(found) or (frame.discontinuity is not None and frame.discontinuity[found[0]]):
        return None
    return np.asarray(frame.boxes[found[0]], np.float64), float(np.hypot(*frame.velocity_mps[found[0], :2]))


def count_problems(
    frame: Frame,
    locate: Locate,
    half_frame_s: float,
    tol: LabelTolerances,
    before: Frame | None = None,
    after: Frame | None = None,
) -> list[Problem]:
    """Stored `num_points` against the points carrying the box's track id, and those inside the box (or
    in the box of frame `before` or `after` on the point's side of the label time)."""
    order = np.argsort(frame.instance_id, kind="stable")
    ids = frame.instance_id[order]
    placed = frame.discontinuity if frame.discontinuity is not None else np.zeros(len(frame.boxes), bool)
    timed = frame.time_offset_s is not None and frame.time_s is not None and frame.label_time_s is not None
    problems = []
    for i, (box, track, stored) in enumerate(
        zip(np.asarray(frame.boxes, np.float64), frame.track_id, frame.num_points)
    ):
        file, row = locate(frame.index, i)
        lo, hi = np.searchsorted(ids, track, "left"), np.searchsorted(ids, track, "right")
        if hi - lo != stored:
            problems.append(
                Problem(
                    file, row, f"num_points is {stored}, the frame has {plural(hi - lo, 'point')} of track id {track}"
                )
            )
            continue
        if placed[i]:
            continue
        grow = tol.box_margin_m + float(np.hypot(*frame.velocity_mps[i, :2])) * half_frame_s
        points = frame.points_m[order[lo:hi]]
        inside = in_box(points, box, grow)
        if timed and not inside.all():
            later = frame.time_s + frame.time_offset_s[order[lo:hi]].astype(np.float64) >= frame.label_time_s
            for side, neighbour in ((later, after), (~later, before)):
                other = _box_of(neighbour, int(track))
                if other is not None:
                    inside |= side & in_box(points, other[0], tol.box_margin_m + other[1] * half_frame_s)
        if int(inside.sum()) != stored:
            problems.append(
                Problem(
                    file,
                    row,
                    f"{plural(int(inside.sum()), 'point')} inside the box (grown by {grow:z.2f} m), num_points is "
                    f"{stored}",
                )
            )
    return problems


def track_problems(
    tracks: Sequence[tuple[int, NDArray, NDArray, NDArray | None]],
    locate: Locate,
    frame_rate_hz: float,
    tol: LabelTolerances,
) -> list[Problem]:
    """Track ids twice in a frame, missing from frames between two sightings, or moving too fast within
    a segment.

    `tracks`: per frame in order, (frame index, track ids (H,), boxes (H, 7), discontinuity (H,) or None).
    """
    problems = []
    last: dict[int, tuple[int, NDArray]] = {}  # track id -> (frame index, box centre) where last seen
    for index, track_id, boxes, placed in tracks:
        ids, counts = np.unique(track_id, return_counts=True)
        for track, count in zip(ids[counts > 1], counts[counts > 1]):
            file, row = locate(index, int(np.flatnonzero(track_id == track)[1]))
            problems.append(Problem(file, row, f"track id {track} appears {count} times in frame {index}"))
        for i, track in enumerate(track_id):
            file, row = locate(index, i)
            centre = np.asarray(boxes[i, :2], np.float64)
            seen = last.get(int(track))
            if seen is not None and seen[0] < index - 1:
                problems.append(
                    Problem(file, row, f"track id {track} is missing from frames {seen[0] + 1}-{index - 1}")
                )
            elif seen is not None and seen[0] == index - 1 and not (placed is not None and placed[i]):
                speed = float(np.linalg.norm(centre - seen[1])) * frame_rate_hz
                if speed > tol.max_speed_mps:
                    problems.append(
                        Problem(
                            file,
                            row,
                            f"track id {track} moved at {speed:.1f} m/s since frame {seen[0]} (limit "
                            f"{tol.max_speed_mps:g})",
                        )
                    )
            last[int(track)] = (index, centre)
    return problems
