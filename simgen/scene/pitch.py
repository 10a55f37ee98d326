"""The pitch: an analytic ground plane (z = 0) with painted lines (IFAB Laws of the Game sizes).

No mesh: a ray's ground hit is solved in closed form (`simgen.render.frame`), and `on_line_at` says
whether the hit point is on a painted line (compiled: the renderer asks it for every ray). Pitch frame of
`simgen.vocab`; metres.
"""

from __future__ import annotations

import numba

from simgen.vocab import PITCH_LENGTH_M, PITCH_WIDTH_M

LINE_WIDTH_M = 0.12
HALF_LENGTH_M = PITCH_LENGTH_M / 2
HALF_WIDTH_M = PITCH_WIDTH_M / 2
CENTRE_CIRCLE_RADIUS_M = 9.15
PENALTY_AREA_DEPTH_M, PENALTY_AREA_HALF_WIDTH_M = 16.5, 20.16
GOAL_AREA_DEPTH_M, GOAL_AREA_HALF_WIDTH_M = 5.5, 9.16
PENALTY_SPOT_M = 11.0
SPOT_RADIUS_M = 0.11
CORNER_ARC_RADIUS_M = 1.0


@numba.njit(cache=True)
def _near(value: float, target: float) -> bool:
    return abs(value - target) <= LINE_WIDTH_M / 2


@numba.njit(cache=True)
def _near_circle(distance2: float, radius: float) -> bool:
    """Whether a point at squared distance `distance2` from a circle's centre lies on its line."""
    return (radius - LINE_WIDTH_M / 2) ** 2 <= distance2 <= (radius + LINE_WIDTH_M / 2) ** 2


@numba.njit(cache=True)
def on_line_at(x: float, y: float) -> bool:
    """True where the ground point (x, y), metres, lies on a painted line (lines are 0.12 m wide)."""
    ax, ay = abs(x), abs(y)
    half_line = LINE_WIDTH_M / 2
    if ax > HALF_LENGTH_M + half_line or ay > HALF_WIDTH_M + half_line:
        return False
    if _near(ay, HALF_WIDTH_M) or _near(ax, HALF_LENGTH_M) or _near(x, 0.0):
        return True
    centre2 = x * x + y * y
    if _near_circle(centre2, CENTRE_CIRCLE_RADIUS_M) or centre2 <= SPOT_RADIUS_M**2:
        return True
    # Penalty and goal areas: the line parallel to the goal line and the two sides.
    for depth, half_width in (
        (PENALTY_AREA_DEPTH_M, PENALTY_AREA_HALF_WIDTH_M),
        (GOAL_AREA_DEPTH_M, GOAL_AREA_HALF_WIDTH_M),
    ):
        front = HALF_LENGTH_M - depth
        if _near(ax, front) and ay <= half_width + half_line:
            return True
        if _near(ay, half_width) and front - half_line <= ax <= HALF_LENGTH_M:
            return True
    spot_x = ax - (HALF_LENGTH_M - PENALTY_SPOT_M)
    spot2 = spot_x * spot_x + y * y
    if spot2 <= SPOT_RADIUS_M**2:
        return True
    # Penalty arc: the part of the 9.15 m circle round the spot outside the penalty area.
    if _near_circle(spot2, CENTRE_CIRCLE_RADIUS_M) and ax < HALF_LENGTH_M - PENALTY_AREA_DEPTH_M:
        return True
    corner_x, corner_y = ax - HALF_LENGTH_M, ay - HALF_WIDTH_M
    return (
        _near_circle(corner_x * corner_x + corner_y * corner_y, CORNER_ARC_RADIUS_M)
        and ax <= HALF_LENGTH_M
        and ay <= HALF_WIDTH_M
    )
