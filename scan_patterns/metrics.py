"""Fidelity metrics of a pattern: how fast it covers the field of view, where its shots go, and how
many land on a person-sized target. All take head-frame `Shots` (a pattern, not a whole sensor).

A field of view `fov` is a circular cone, its full angle in degrees (Mid-40, Mid-70), or a box
(azimuth min, max, elevation min, max) in degrees (Avia, Horizon, Tele-15, HAP, Mid-360).
Projection: in a cone a direction at off-axis angle rho (from the boresight x) and angle psi about
it (from +y towards +z) maps to (u, v) = rho (cos psi, sin psi) in degrees, the azimuthal-
equidistant projection, and the field of view is the disc rho <= fov / 2; in a box (u, v) is
(azimuth, elevation) in degrees, the field of view the box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scan_patterns.shots import Shots, dirs_from_off_axis

COVERAGE_TIMES_S = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0)
CELL_SIZES_DEG = (0.1, 0.2, 0.3)
BEAM_DIVERGENCE_DEG = (0.03, 0.28)  # Livox Mid-40 datasheet: horizontal (y) x vertical (z), full angles
TARGET_SIZE_M = (0.5, 1.8)  # width x height of the upright person-sized target

FieldOfView = float | tuple[float, float, float, float]  # cone angle, or (az min, max, el min, max); degrees


def projected_deg(dirs: NDArray) -> NDArray[np.float64]:
    """(N, 2) azimuthal-equidistant coordinates (u along +y, v along +z), degrees."""
    d = np.asarray(dirs, np.float64)
    lateral = np.hypot(d[:, 1], d[:, 2])
    rho_deg = np.degrees(np.arctan2(lateral, d[:, 0]))
    scale = np.divide(rho_deg, lateral, out=np.zeros_like(lateral), where=lateral > 0)
    return np.column_stack([d[:, 1] * scale, d[:, 2] * scale])


def field_coords(dirs: NDArray, fov: FieldOfView) -> NDArray[np.float64]:
    """(N, 2) coordinates (degrees) of unit vectors in the projection of the field of view `fov`."""
    if np.ndim(fov) == 0:
        return projected_deg(dirs)
    d = np.asarray(dirs, np.float64)
    azimuth = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    return np.column_stack([azimuth, np.degrees(np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))])


def _grid(fov: FieldOfView, cell_deg: float) -> tuple[NDArray[np.float64], int, tuple[int, int], NDArray[np.bool_]]:
    """The cell grid of a field of view: the origin of the coordinates its cells count from, the
    index of the cell at that origin, its size (cells along u, v) and which cells (flattened,
    u major) have their centres in the field of view."""
    if np.ndim(fov) == 0:
        half = int(np.ceil(fov / 2.0 / cell_deg)) + 1  # grid of (2 half)^2 cells round the boresight
        centres = (np.arange(-half, half) + 0.5) * cell_deg
        return (
            np.zeros(2),
            half,
            (2 * half, 2 * half),
            (np.hypot(centres[:, None], centres[None, :]) <= fov / 2.0).ravel(),
        )
    az_lo, az_hi, el_lo, el_hi = fov
    size = (int(np.ceil((az_hi - az_lo) / cell_deg)), int(np.ceil((el_hi - el_lo) / cell_deg)))
    u = az_lo + (np.arange(size[0]) + 0.5) * cell_deg
    v = el_lo + (np.arange(size[1]) + 0.5) * cell_deg
    return np.array([az_lo, el_lo]), 0, size, ((u[:, None] <= az_hi) & (v[None, :] <= el_hi)).ravel()


def _cells_hit(uv: NDArray, cell_deg: float, footprint_deg: tuple[float, float] | None):
    """(shot index, cell i, cell j) of every cell a shot touches: its own, or all its footprint overlaps."""
    base = np.floor(uv / cell_deg).astype(np.int64)
    if footprint_deg is None:
        return np.arange(len(uv)), base[:, 0], base[:, 1]
    a, b = footprint_deg[0] / 2.0, footprint_deg[1] / 2.0  # semi-axes of the elliptical footprint
    reach_i, reach_j = int(np.ceil(a / cell_deg)), int(np.ceil(b / cell_deg))
    shot_parts, i_parts, j_parts = [], [], []
    for di in range(-reach_i, reach_i + 1):
        for dj in range(-reach_j, reach_j + 1):
            i, j = base[:, 0] + di, base[:, 1] + dj
            # nearest point of the cell to the beam centre, in units of the semi-axes
            du = (np.clip(uv[:, 0], i * cell_deg, (i + 1) * cell_deg) - uv[:, 0]) / a
            dv = (np.clip(uv[:, 1], j * cell_deg, (j + 1) * cell_deg) - uv[:, 1]) / b
            hit = np.flatnonzero(du * du + dv * dv <= 1.0)
            shot_parts.append(hit)
            i_parts.append(i[hit])
            j_parts.append(j[hit])
    return np.concatenate(shot_parts), np.concatenate(i_parts), np.concatenate(j_parts)


def coverage_curve(
    shots: Shots,
    fov: FieldOfView,
    times_s=COVERAGE_TIMES_S,
    cell_deg: float = 0.2,
    footprint_deg: tuple[float, float] | None = None,
) -> NDArray[np.float64]:
    """Fraction of the field of view's cells hit at least once within T s of the window's start, per T.

    Cells are `cell_deg` squares of the projection whose centres lie in the field of view. A shot
    hits its cell, or with `footprint_deg` = (horizontal, vertical) beam widths (e.g.
    BEAM_DIVERGENCE_DEG), every cell its elliptical footprint overlaps. T beyond the window: NaN.
    """
    origin, first, (cols, rows), in_fov = _grid(fov, cell_deg)
    shot, i, j = _cells_hit(field_coords(shots.dirs, fov) - origin, cell_deg, footprint_deg)
    i, j = i + first, j + first
    inside = (i >= 0) & (i < cols) & (j >= 0) & (j < rows)
    cell = i[inside] * rows + j[inside]
    first_hit = np.full(in_fov.size, np.inf)
    np.minimum.at(first_hit, cell, shots.t_s[shot[inside]] - shots.t0_s)
    first_hit = np.sort(first_hit[in_fov])
    times = np.asarray(times_s, np.float64)
    covered = np.searchsorted(first_hit, times, side="right") / in_fov.sum()
    return np.where(times <= shots.duration_s + 1e-9, covered, np.nan)


@dataclass(frozen=True)
class RadialProfile:
    off_axis_deg: NDArray[np.float64]  # bin centres: off-axis angle (cone), elevation (box)
    shots_per_sr_s: NDArray[np.float64]  # shots per steradian per second


def radial_density(shots: Shots, fov: FieldOfView, bin_deg: float = 0.5) -> RadialProfile:
    """Shots per solid angle and second in rings of `bin_deg` off-axis angle out to fov / 2 (cone),
    or in bands of `bin_deg` elevation across the box's azimuths (box)."""
    if np.ndim(fov) == 0:
        edges = np.arange(0.0, fov / 2.0 + bin_deg / 2.0, bin_deg)
        counts, _ = np.histogram(np.hypot(*projected_deg(shots.dirs).T), edges)
        solid_angle = 2.0 * np.pi * -np.diff(np.cos(np.radians(edges)))
    else:
        az_lo, az_hi, el_lo, el_hi = fov
        edges = np.arange(el_lo, el_hi + bin_deg / 2.0, bin_deg)
        uv = field_coords(shots.dirs, fov)
        counts, _ = np.histogram(uv[(uv[:, 0] >= az_lo) & (uv[:, 0] <= az_hi), 1], edges)
        solid_angle = np.radians(az_hi - az_lo) * np.diff(np.sin(np.radians(edges)))
    return RadialProfile((edges[1:] + edges[:-1]) / 2.0, counts / solid_angle / shots.duration_s)


def target_points_per_frame(
    shots: Shots,
    range_m: float,
    off_axis_deg: float,
    frame_rate_hz: float = 10.0,
    around_deg: float = 0.0,
    size_m: tuple[float, float] = TARGET_SIZE_M,
) -> NDArray[np.int64]:
    """Shots hitting an upright rectangle (width x height, metres) facing the sensor, per frame.

    The target's centre is `range_m` away at `off_axis_deg` from the boresight, `around_deg` about it
    (0: towards +y, horizontal; 90: straight up). Frames are 1 / frame_rate_hz from the window start.
    """
    centre_dir = dirs_from_off_axis(np.radians([off_axis_deg]), np.radians([around_deg]))[0]
    normal = np.array([centre_dir[0], centre_dir[1], 0.0])
    normal /= np.linalg.norm(normal)
    across = np.array([-normal[1], normal[0], 0.0])
    centre = range_m * centre_dir
    d = np.asarray(shots.dirs, np.float64)
    facing = d @ normal
    s = np.divide(centre @ normal, facing, out=np.full(len(d), -1.0), where=facing > 1e-9)
    offset = d * s[:, None] - centre
    hit = (s > 0) & (np.abs(offset @ across) <= size_m[0] / 2) & (np.abs(offset[:, 2]) <= size_m[1] / 2)
    frames = max(1, round(shots.duration_s * frame_rate_hz))
    frame = np.ceil((shots.t_s[hit] - shots.t0_s) * frame_rate_hz - 1e-6).astype(np.int64) - 1
    return np.bincount(np.clip(frame, 0, frames - 1), minlength=frames)


@dataclass(frozen=True)
class PatternComparison:
    """Metric curves of two patterns side by side, and their largest differences."""

    names: tuple[str, str]
    times_s: NDArray[np.float64]
    coverage: dict[float, tuple[NDArray, NDArray]]  # cell size (deg) -> the two coverage curves
    radial: tuple[RadialProfile, RadialProfile]
    targets: tuple[tuple[float, float], ...]  # (range m, off-axis deg)
    target_points: tuple[NDArray, NDArray]  # mean points per frame at each target

    @property
    def max_coverage_diff(self) -> dict[float, float]:
        """Largest |difference| of coverage (fraction) over T, per cell size."""
        return {c: float(np.nanmax(np.abs(a - b))) for c, (a, b) in self.coverage.items()}

    @property
    def max_density_rel_diff(self) -> float:
        """Largest |a - b| / b of the radial density over rings where b has shots."""
        a, b = (p.shots_per_sr_s for p in self.radial)
        return float(np.max(np.abs(a - b)[b > 0] / b[b > 0]))

    @property
    def max_target_diff(self) -> float:
        """Largest |difference| of mean points per frame over the targets."""
        return float(np.max(np.abs(self.target_points[0] - self.target_points[1])))

    def markdown(self) -> str:
        a, b = self.names
        lines = [f"| metric | {a} | {b} | difference |", "| --- | ---: | ---: | ---: |"]
        for cell, (ca, cb) in self.coverage.items():
            for t, x, y in zip(self.times_s, ca, cb):
                lines.append(f"| coverage {cell:g} deg cells, T = {t:g} s | {x:.2%} | {y:.2%} | {x - y:+.2%} |")
        for (r, off), x, y in zip(self.targets, *self.target_points):
            lines.append(
                f"| points/frame on target at {r:g} m, {off:g} deg off-axis | {x:.2f} | {y:.2f} | {x - y:+.2f} |"
            )
        for rho, x, y in zip(self.radial[0].off_axis_deg, self.radial[0].shots_per_sr_s, self.radial[1].shots_per_sr_s):
            lines.append(f"| shots/sr/s at {rho:g} deg off-axis | {x:.4g} | {y:.4g} | {x - y:+.3g} |")
        return "\n".join(lines)


DEFAULT_TARGETS = ((25.0, 0.0), (50.0, 0.0), (100.0, 0.0), (50.0, 10.0), (50.0, 18.0))


def compare(
    a: Shots,
    b: Shots,
    fov: FieldOfView,
    names: tuple[str, str] = ("a", "b"),
    times_s=COVERAGE_TIMES_S,
    cells_deg=CELL_SIZES_DEG,
    targets=DEFAULT_TARGETS,
    frame_rate_hz: float = 10.0,
) -> PatternComparison:
    """Coverage curves, radial density and target points of two patterns over their windows."""
    return PatternComparison(
        names=names,
        times_s=np.asarray(times_s, np.float64),
        coverage={c: (coverage_curve(a, fov, times_s, c), coverage_curve(b, fov, times_s, c)) for c in cells_deg},
        radial=(radial_density(a, fov), radial_density(b, fov)),
        targets=tuple(targets),
        target_points=tuple(
            np.array([target_points_per_frame(s, r, off, frame_rate_hz).mean() for r, off in targets]) for s in (a, b)
        ),
    )
