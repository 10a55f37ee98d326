"""The pitch: an analytic ground plane (z = 0) with painted lines (IFAB Laws of the Game sizes).

No mesh: a ray's ground hit is solved in closed form, and `on_line` says whether the hit point
is on a painted line. Pitch frame of `simgen.skeleton`; metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from simgen.skeleton import PITCH_LENGTH_M, PITCH_WIDTH_M

LINE_WIDTH_M = 0.12
HALF_LENGTH_M = PITCH_LENGTH_M / 2
HALF_WIDTH_M = PITCH_WIDTH_M / 2
CENTRE_CIRCLE_RADIUS_M = 9.15
PENALTY_AREA_DEPTH_M, PENALTY_AREA_HALF_WIDTH_M = 16.5, 20.16
GOAL_AREA_DEPTH_M, GOAL_AREA_HALF_WIDTH_M = 5.5, 9.16
PENALTY_SPOT_M = 11.0
SPOT_RADIUS_M = 0.11
CORNER_ARC_RADIUS_M = 1.0


def ground_hit(origins: NDArray, directions: NDArray) -> NDArray[np.float64]:
    """Ray parameter t where origin + t * direction meets z = 0; inf for rays not going down."""
    dz = directions[:, 2].astype(np.float64)
    t = np.full(len(directions), np.inf)
    down = dz < 0
    t[down] = -origins[down, 2] / dz[down]
    return t


def _near(value: NDArray, target: float) -> NDArray[np.bool_]:
    return np.abs(value - target) <= LINE_WIDTH_M / 2


def on_line(x_m: NDArray, y_m: NDArray) -> NDArray[np.bool_]:
    """True where a ground point (x, y) lies on a painted line (lines are 0.12 m wide)."""
    x = np.asarray(x_m, dtype=np.float64)
    y = np.asarray(y_m, dtype=np.float64)
    ax, ay = np.abs(x), np.abs(y)
    inside_x = ax <= HALF_LENGTH_M + LINE_WIDTH_M / 2
    inside_y = ay <= HALF_WIDTH_M + LINE_WIDTH_M / 2
    lines = (_near(ay, HALF_WIDTH_M) & inside_x) | (_near(ax, HALF_LENGTH_M) & inside_y)
    lines |= _near(x, 0.0) & inside_y
    centre_distance = np.hypot(x, y)
    lines |= _near(centre_distance, CENTRE_CIRCLE_RADIUS_M) | (centre_distance <= SPOT_RADIUS_M)
    # Penalty and goal areas: the line parallel to the goal line and the two sides.
    for depth, half_width in ((PENALTY_AREA_DEPTH_M, PENALTY_AREA_HALF_WIDTH_M), (GOAL_AREA_DEPTH_M, GOAL_AREA_HALF_WIDTH_M)):
        front = HALF_LENGTH_M - depth
        lines |= _near(ax, front) & (ay <= half_width + LINE_WIDTH_M / 2)
        lines |= _near(ay, half_width) & (ax >= front - LINE_WIDTH_M / 2) & (ax <= HALF_LENGTH_M)
    spot_x = HALF_LENGTH_M - PENALTY_SPOT_M
    spot_distance = np.hypot(ax - spot_x, y)
    lines |= spot_distance <= SPOT_RADIUS_M
    # Penalty arc: the part of the 9.15 m circle round the spot outside the penalty area.
    lines |= _near(spot_distance, CENTRE_CIRCLE_RADIUS_M) & (ax < HALF_LENGTH_M - PENALTY_AREA_DEPTH_M)
    corner_distance = np.hypot(ax - HALF_LENGTH_M, ay - HALF_WIDTH_M)
    lines |= _near(corner_distance, CORNER_ARC_RADIUS_M) & (ax <= HALF_LENGTH_M) & (ay <= HALF_WIDTH_M)
    return lines
