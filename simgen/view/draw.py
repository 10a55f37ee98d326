"""A frame as a picture (OpenCV drawing into numpy arrays, BGR): a bird's-eye view of the pitch
(points coloured by height or intensity, the painted lines, boxes with track ids and heading
arrows, the sensors and their heads' boresights) above a side view (x across, z up, looking
along +y; z stretched by SIDE_Z_STRETCH).

Pixels: x grows to the right, the pitch's +y (left of the x axis) is up in the bird's-eye view.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

from simgen.scene.pitch import (
    CENTRE_CIRCLE_RADIUS_M,
    CORNER_ARC_RADIUS_M,
    GOAL_AREA_DEPTH_M,
    GOAL_AREA_HALF_WIDTH_M,
    HALF_LENGTH_M,
    HALF_WIDTH_M,
    PENALTY_AREA_DEPTH_M,
    PENALTY_AREA_HALF_WIDTH_M,
    PENALTY_SPOT_M,
)

if TYPE_CHECKING:
    from simgen.datasets.frame import Frame
    from simgen.scan.sensor import Sensor

COLOUR_RANGE = {"height": (-0.3, 2.2), "intensity": (0.0, 150.0)}  # metres; Livox diffuse reflectivity 0-150
UNITS = {"height": "m", "intensity": ""}
MARGIN_M = 6.0  # round the pitch, and round the sensors
SIDE_Z_M = (-0.5, 3.0)
SIDE_Z_STRETCH = 4.0
HEADER_PX = 28
BORESIGHT_M = 25.0
ARROW_M = 1.5
BACKGROUND = (28, 48, 28)
LINE_COLOUR = (150, 170, 150)
TEXT_COLOUR = (235, 235, 235)
# Box colours (BGR) off the turbo map of the points: white and magenta teams, yellow officials.
TEAM_COLOURS = {"left": (255, 255, 255), "right": (255, 80, 255), "official": (0, 230, 255)}
CLASS_COLOURS = {"Pedestrian": (255, 255, 255), "Official": (0, 230, 255)}
UNSEEN_COLOUR = (140, 140, 140)  # a box with no point on it
SENSOR_COLOUR = (255, 255, 255)
FONT = cv2.FONT_HERSHEY_SIMPLEX


@dataclass(frozen=True)
class Canvas:
    """Metres to pixels: the bird's-eye view's extent and scale, and the side view's rows."""

    x_range_m: tuple[float, float]
    y_range_m: tuple[float, float]
    px_per_m: float

    @property
    def width(self) -> int:
        return _even((self.x_range_m[1] - self.x_range_m[0]) * self.px_per_m)

    @property
    def bev_height(self) -> int:
        return _even((self.y_range_m[1] - self.y_range_m[0]) * self.px_per_m)

    @property
    def side_height(self) -> int:
        return _even((SIDE_Z_M[1] - SIDE_Z_M[0]) * self.px_per_m * SIDE_Z_STRETCH)

    @property
    def height(self) -> int:
        return HEADER_PX + self.bev_height + self.side_height

    def bev(self, x_m: NDArray, y_m: NDArray) -> NDArray[np.int32]:
        """(N, 2) pixel columns and rows of pitch points in the bird's-eye view."""
        col = (np.asarray(x_m) - self.x_range_m[0]) * self.px_per_m
        row = HEADER_PX + (self.y_range_m[1] - np.asarray(y_m)) * self.px_per_m
        return np.stack([col, row], axis=-1).round().astype(np.int32)

    def side(self, x_m: NDArray, z_m: NDArray) -> NDArray[np.int32]:
        """(N, 2) pixel columns and rows in the side view."""
        col = (np.asarray(x_m) - self.x_range_m[0]) * self.px_per_m
        row = HEADER_PX + self.bev_height + (SIDE_Z_M[1] - np.asarray(z_m)) * self.px_per_m * SIDE_Z_STRETCH
        return np.stack([col, row], axis=-1).round().astype(np.int32)


def _even(pixels: float) -> int:
    """Video encoders want even sizes."""
    return int(np.ceil(pixels / 2.0)) * 2


def canvas_for(sensors: list[Sensor], px_per_m: float) -> Canvas:
    """The pitch and every sensor, with MARGIN_M round them."""
    xs = [-HALF_LENGTH_M, HALF_LENGTH_M, *(s.origin_m[0] for s in sensors)]
    ys = [-HALF_WIDTH_M, HALF_WIDTH_M, *(s.origin_m[1] for s in sensors)]
    return Canvas((min(xs) - MARGIN_M, max(xs) + MARGIN_M), (min(ys) - MARGIN_M, max(ys) + MARGIN_M), px_per_m)


def _arc(
    canvas: Canvas, centre: tuple[float, float], radius_m: float, from_rad: float, to_rad: float
) -> NDArray[np.int32]:
    angles = np.linspace(from_rad, to_rad, 64)
    return canvas.bev(centre[0] + radius_m * np.cos(angles), centre[1] + radius_m * np.sin(angles))


def pitch_lines(canvas: Canvas) -> list[NDArray[np.int32]]:
    """Polylines (pixels) of the painted lines of `simgen.scene.pitch`."""
    def rect(x0, y0, x1, y1):
        return canvas.bev(np.array([x0, x1, x1, x0, x0]), np.array([y0, y0, y1, y1, y0]))

    L, W = HALF_LENGTH_M, HALF_WIDTH_M
    lines = [rect(-L, -W, L, W), canvas.bev(np.array([0.0, 0.0]), np.array([-W, W])),
             _arc(canvas, (0.0, 0.0), CENTRE_CIRCLE_RADIUS_M, 0.0, 2 * np.pi)]
    for side in (-1.0, 1.0):
        for depth, half in (
            (PENALTY_AREA_DEPTH_M, PENALTY_AREA_HALF_WIDTH_M),
            (GOAL_AREA_DEPTH_M, GOAL_AREA_HALF_WIDTH_M),
        ):
            lines.append(rect(side * L, -half, side * (L - depth), half))
        spot = side * (L - PENALTY_SPOT_M)
        reach = np.arccos((PENALTY_AREA_DEPTH_M - PENALTY_SPOT_M) / CENTRE_CIRCLE_RADIUS_M)  # the arc outside the area
        facing = np.pi if side > 0 else 0.0
        lines.append(_arc(canvas, (spot, 0.0), CENTRE_CIRCLE_RADIUS_M, facing - reach, facing + reach))
        lines.append(_arc(canvas, (spot, 0.0), 0.15, 0.0, 2 * np.pi))
        for corner_y in (-1.0, 1.0):
            start = np.arctan2(-corner_y, -side)
            lines.append(
                _arc(canvas, (side * L, corner_y * W), CORNER_ARC_RADIUS_M, start - np.pi / 4, start + np.pi / 4)
            )
    return lines


def background(canvas: Canvas, sensors: list[Sensor]) -> NDArray[np.uint8]:
    """The picture every frame starts from: pitch lines, sensors, boresights, the side view's ground."""
    image = np.full((canvas.height, canvas.width, 3), BACKGROUND, np.uint8)
    image[:HEADER_PX] = 0
    cv2.polylines(image, pitch_lines(canvas), False, LINE_COLOUR, 1, cv2.LINE_AA)
    for sensor in sensors:
        at = canvas.bev(*sensor.origin_m[:2])
        for azimuth in sensor.boresight_azimuth_rad:
            end = sensor.origin_m[:2] + BORESIGHT_M * np.array([np.cos(azimuth), np.sin(azimuth)])
            cv2.line(image, tuple(at), tuple(canvas.bev(*end)), SENSOR_COLOUR, 1, cv2.LINE_AA)
        cv2.circle(image, tuple(at), 5, SENSOR_COLOUR, -1, cv2.LINE_AA)
        cv2.putText(image, sensor.name, tuple(at + [8, 4]), FONT, 0.45, SENSOR_COLOUR, 1, cv2.LINE_AA)
    top = HEADER_PX + canvas.bev_height
    image[top : top + 2] = 90
    ground = canvas.side(np.array(canvas.x_range_m), np.zeros(2))
    cv2.line(image, tuple(ground[0]), tuple(ground[1]), LINE_COLOUR, 1)
    cv2.putText(
        image,
        f"side view, looking along +y; height x{SIDE_Z_STRETCH:g}",
        (6, top + 18),
        FONT,
        0.45,
        TEXT_COLOUR,
        1,
        cv2.LINE_AA,
    )
    return image


def point_colours(values: NDArray, colouring: str) -> NDArray[np.uint8]:
    """(N, 3) BGR colours of heights (m) or intensities on the turbo colour map."""
    lo, hi = COLOUR_RANGE[colouring]
    scaled = np.clip((np.asarray(values, np.float64) - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)
    return cv2.applyColorMap(scaled.reshape(-1, 1), cv2.COLORMAP_TURBO).reshape(-1, 3)


def _splat(
    image: NDArray[np.uint8],
    pixels: NDArray[np.int32],
    colours: NDArray[np.uint8],
    order: NDArray,
    rows: tuple[int, int],
) -> None:
    """2 x 2 pixel dots inside the image rows [rows); where dots overlap, the later in `order` shows."""
    offsets = np.array([[0, 0], [1, 0], [0, 1], [1, 1]])
    spots = (pixels[order][None, :, :] + offsets[:, None, :]).reshape(-1, 2)
    rank = np.tile(np.arange(len(order)), len(offsets))
    keep = (spots[:, 0] >= 0) & (spots[:, 0] < image.shape[1]) & (spots[:, 1] >= rows[0]) & (spots[:, 1] < rows[1])
    winner = np.full(image.shape[0] * image.shape[1], -1, np.int64)
    np.maximum.at(winner, spots[keep, 1] * image.shape[1] + spots[keep, 0], rank[keep])
    hit = np.flatnonzero(winner >= 0)
    image.reshape(-1, 3)[hit] = colours[order][winner[hit]]


def _box_colour(frame: Frame, i: int) -> tuple[int, int, int]:
    if frame.num_points is not None and frame.num_points[i] == 0:
        return UNSEEN_COLOUR
    if frame.team is not None:
        return TEAM_COLOURS.get(str(frame.team[i]), CLASS_COLOURS["Pedestrian"])
    return CLASS_COLOURS.get(str(frame.class_name[i]), CLASS_COLOURS["Pedestrian"])


def _boxes(image: NDArray[np.uint8], canvas: Canvas, frame: Frame) -> None:
    for i, (x, y, z, length, width, height, yaw) in enumerate(np.asarray(frame.boxes, np.float64)):
        colour = _box_colour(frame, i)
        heading, left = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
        corners = np.array([[x, y]]) + np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) @ np.array(
            [heading * length / 2, left * width / 2]
        )
        cv2.polylines(image, [canvas.bev(corners[:, 0], corners[:, 1])], True, colour, 1, cv2.LINE_AA)
        centre, tip = canvas.bev(x, y), canvas.bev(*(np.array([x, y]) + ARROW_M * heading))
        cv2.arrowedLine(image, tuple(centre), tuple(tip), colour, 1, cv2.LINE_AA, tipLength=0.35)
        label = str(frame.track_id[i]) if frame.track_id is not None else str(i)
        cv2.putText(image, label, tuple(canvas.bev(x, y) + [6, -6]), FONT, 0.4, colour, 1, cv2.LINE_AA)
        reach = (abs(length * np.cos(yaw)) + abs(width * np.sin(yaw))) / 2  # the box's half extent along x
        low, high = canvas.side(np.array([x - reach, x + reach]), np.array([z - height / 2, z + height / 2]))
        cv2.rectangle(image, tuple(low), tuple(high), colour, 1)


def _legend(image: NDArray[np.uint8], colouring: str) -> None:
    """A colour bar at the header's right end."""
    lo, hi = COLOUR_RANGE[colouring]
    width = 200
    left = image.shape[1] - width - 150
    bar = point_colours(np.linspace(lo, hi, width), colouring)
    image[8:20, left : left + width] = bar[None, :, :]
    unit = f" {UNITS[colouring]}" if UNITS[colouring] else ""
    cv2.putText(image, f"{lo:g}", (left - 40, 19), FONT, 0.45, TEXT_COLOUR, 1, cv2.LINE_AA)
    cv2.putText(image, f"{hi:g}{unit} {colouring}", (left + width + 6, 19), FONT, 0.45, TEXT_COLOUR, 1, cv2.LINE_AA)


def render_frame(frame: Frame, canvas: Canvas, base: NDArray[np.uint8], colouring: str) -> NDArray[np.uint8]:
    """The frame drawn on a copy of `base` (from `background`)."""
    image = base.copy()
    points = np.asarray(frame.points_m, np.float64)
    values = points[:, 2] if colouring == "height" else frame.intensity
    colours = point_colours(values, colouring)
    bev_rows = (HEADER_PX, HEADER_PX + canvas.bev_height)
    _splat(image, canvas.bev(points[:, 0], points[:, 1]), colours, np.argsort(points[:, 2], kind="stable"), bev_rows)
    depth = np.argsort(-points[:, 1], kind="stable")  # side view: the nearer (smaller y) points on top
    _splat(image, canvas.side(points[:, 0], points[:, 2]), colours, depth, (bev_rows[1] + 2, canvas.height))
    _boxes(image, canvas, frame)
    time = f"  t = {frame.time_s:.2f} s" if frame.time_s is not None else ""
    header = f"{frame.clip}  frame {frame.index}{time}  {len(points):,} points  {len(frame.boxes)} boxes"
    cv2.putText(image, header, (8, 19), FONT, 0.5, TEXT_COLOUR, 1, cv2.LINE_AA)
    _legend(image, colouring)
    return image
