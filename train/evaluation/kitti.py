"""Tracks (and ground truth) as KITTI tracking label files, for outside evaluators.

The lines are those simgen.datasets writes for its ``kitti_tracking`` labels,
``frame track_id type truncated occluded alpha x1 y1 x2 y2 h w l x y z rotation_y``, tracker lines
adding the score, in the same virtual camera (simgen.datasets.kitti_camera: 150 m behind the centre
spot, so every box on the pitch is 94-206 m in front of it, at KITTI's own scale for float32 tools;
2D boxes are its projected corners, at least 30 px tall for anything 0.25 m tall, above the 25 px
under which KITTI's devkit drops a box). An evaluator such as AB3DMOT's ``evaluate_kitti3dmot.py`` thus scores these
files against a simgen KITTI tracking dataset's labels as they are.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from simgen.datasets.formats.kitti import box_fields
from train.tracking.types import GroundTruthFrame, TrackedFrame


def kitti_lines(
    frames: Sequence[TrackedFrame] | Sequence[GroundTruthFrame],
    object_type: str = "Pedestrian",
    numbers: Sequence[int] | None = None,
) -> list[str]:
    """The label lines of a clip (frames numbered from 0, or by `numbers`); tracker frames add the score column."""
    lines = []
    for index, frame in zip(range(len(frames)) if numbers is None else numbers, frames):
        scores = getattr(frame, "scores", None)
        for i, (track_id, fields) in enumerate(zip(frame.ids.tolist(), box_fields(frame.boxes))):
            line = f"{index} {track_id} {object_type} 0 0 {fields}"
            lines.append(line if scores is None else f"{line} {scores[i]:.6f}")
    return lines


def write_kitti_tracking(
    path: str | Path, frames: Sequence[TrackedFrame] | Sequence[GroundTruthFrame], object_type: str = "Pedestrian"
) -> None:
    """Write one clip (one KITTI sequence, e.g. ``label_02/0000.txt``) to path."""
    Path(path).write_text("".join(line + "\n" for line in kitti_lines(frames, object_type)))
