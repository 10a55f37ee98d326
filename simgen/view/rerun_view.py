"""A clip as a Rerun recording (.rrd): open it with `rerun FILE.rrd` for an interactive 3D view.

Entities, in the pitch frame (metres, z up):

- `world/pitch` (static): the painted lines.
- `world/sensors/<name>` (static): the sensor's pose (`Transform3D`); below it `frustum` holds each
  head's field of view as a cone of line strips (rim at FRUSTUM_RANGE_M), in the sensor's own frame.
- `world/points`: the frame's points, coloured by height or intensity (the turbo map of `simgen view`).
- `world/boxes`: the humanoids' boxes (`Boxes3D`, rotated by their yaw), labelled with their track ids;
  `world/headings`: an arrow along each box's heading.

Every frame is logged on two timelines, `frame` (its index) and `game_time` (seconds of game time, the
clock of every simgen output): its points at the sweep's start (`Frame.time_s`), its boxes and headings
at the label time (`Frame.label_time_s`, the middle of the sweep), where the ROS 2 bags put their
markers; Rerun's wall-clock `log_time` is left out. The recording id is the dataset's
folder name and the clip id.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from simgen.view.draw import ARROW_M, HEADER_PX, Canvas, pitch_lines, point_colours
from simgen.view.output import atomic_suffixed

if TYPE_CHECKING:
    from simgen.datasets.frame import Frame
    from simgen.datasets.reader import Dataset
    from simgen.scan.sensor import Sensor

APPLICATION_ID = "simgen"
FRUSTUM_RANGE_M = 20.0
RIM_SEGMENTS = 32
POINT_RADIUS_M = 0.04
LINE_COLOUR = (150, 170, 150)
SENSOR_COLOUR = (255, 255, 255)
CLASS_COLOURS = {"Pedestrian": (255, 255, 255), "Official": (255, 230, 0)}  # RGB
UNSEEN_COLOUR = (140, 140, 140)  # a box with no point on it


def pitch_strips() -> list[NDArray[np.float64]]:
    """The painted lines as 3D polylines on z = 0, from the bird's-eye view's geometry."""
    canvas = Canvas((0.0, 1.0), (0.0, 1.0), 1000.0)  # 1 mm pixels: the view's polylines, back in metres
    strips = []
    for pixels in pitch_lines(canvas):
        x = pixels[:, 0] / canvas.px_per_m + canvas.x_range_m[0]
        y = canvas.y_range_m[1] - (pixels[:, 1] - HEADER_PX) / canvas.px_per_m
        strips.append(np.column_stack([x, y, np.zeros(len(x))]))
    return strips


def frustum_strips(sensor: Sensor) -> list[NDArray[np.float64]]:
    """Per head, rays from the origin to its field of view's rim and the rim itself (sensor frame, metres)."""
    strips = []
    for boresight, half_deg in zip(sensor.boresights, sensor.half_fov_deg):
        side = np.cross(boresight, [0.0, 0.0, 1.0])
        side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-9 else np.array([0.0, 1.0, 0.0])
        up = np.cross(side, boresight)
        angles = np.linspace(0.0, 2 * np.pi, RIM_SEGMENTS + 1)
        half = np.radians(half_deg)
        rim = FRUSTUM_RANGE_M * (
            np.cos(half) * boresight + np.sin(half) * (np.cos(angles)[:, None] * side + np.sin(angles)[:, None] * up)
        )
        strips.append(rim)
        strips += [np.array([np.zeros(3), rim[k]]) for k in range(0, RIM_SEGMENTS, RIM_SEGMENTS // 4)]
    return strips


def _rgb(bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
    return np.ascontiguousarray(bgr[:, ::-1])


def _box_colours(frame: Frame) -> NDArray[np.uint8]:
    colours = np.array(
        [CLASS_COLOURS.get(str(name), CLASS_COLOURS["Pedestrian"]) for name in frame.class_name], np.uint8
    ).reshape(-1, 3)
    if frame.num_points is not None:
        colours[np.asarray(frame.num_points) == 0] = UNSEEN_COLOUR
    return colours


def log_frame(rec, frame: Frame, colouring: str) -> None:
    """One frame's points at its sweep start, its boxes and headings at its label time."""
    import rerun as rr

    rec.set_time("frame", sequence=frame.index)
    rec.set_time("game_time", duration=frame.time_s)
    points = np.asarray(frame.points_m, np.float32)
    values = points[:, 2] if colouring == "height" else frame.intensity
    rec.log("world/points", rr.Points3D(points, colors=_rgb(point_colours(values, colouring)), radii=POINT_RADIUS_M))
    boxes = np.asarray(frame.boxes, np.float64).reshape(-1, 7)
    yaw = boxes[:, 6]
    ids = frame.track_id if frame.track_id is not None else np.arange(len(boxes))
    colours = _box_colours(frame)
    quaternions = np.column_stack([np.zeros((len(boxes), 2)), np.sin(yaw / 2), np.cos(yaw / 2)])  # x, y, z, w
    rec.set_time("game_time", duration=frame.label_time_s)
    rec.log("world/boxes", rr.Boxes3D(
        centers=boxes[:, :3], half_sizes=boxes[:, 3:6] / 2, quaternions=quaternions, colors=colours,
        labels=[str(int(i)) for i in ids], show_labels=True,
    ))
    heading = ARROW_M * np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(len(yaw))])
    rec.log("world/headings", rr.Arrows3D(origins=boxes[:, :3], vectors=heading, colors=colours))


def log_static(rec, sensors: list[Sensor]) -> None:
    import rerun as rr

    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rec.log("world/pitch", rr.LineStrips3D(pitch_strips(), colors=LINE_COLOUR), static=True)
    for sensor in sensors:
        path = f"world/sensors/{sensor.name}"
        rec.log(path, rr.Transform3D(translation=sensor.origin_m, mat3x3=sensor.rotation), static=True)
        rec.log(f"{path}/frustum", rr.LineStrips3D(frustum_strips(sensor), colors=SENSOR_COLOUR), static=True)


def write_recording(dataset: Dataset, clip: str, frames: range, path: Path, colouring: str) -> int:
    """Write frames `frames` of `clip` to the .rrd file `path` (atomically); returns the frames written."""
    import rerun as rr
    from tqdm import tqdm

    sensors = list(dataset.manifest.sensors)
    rec = rr.RecordingStream(
        APPLICATION_ID, recording_id=f"{dataset.root.resolve().name}.{clip}", send_properties=False
    )
    rr.set_log_time_enabled(False, recording=rec)
    with atomic_suffixed(path) as tmp:
        rec.save(tmp)
        log_static(rec, sensors)
        for index in tqdm(frames, unit="frame", desc=f"{clip} -> {path.name}", dynamic_ncols=True):
            log_frame(rec, dataset.frame(clip, index), colouring)
        rec.flush()
        rec.disconnect()
    return len(frames)
