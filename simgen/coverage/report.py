"""The coverage report of one or more rigs: heatmaps over the pitch (drawn with its lines) per rig and per
sensor, the rigs side by side, tables by distance and of shares, a CSV of every rig's cells, and one verdict
per rig (`simgen.qa.report`'s page: index.html self-contained, report.md beside plots/*.png)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm
from numpy.typing import NDArray

from simgen.atomic import atomic_path
from simgen.coverage.grid import GridCoverage
from simgen.coverage.match import MatchCoverage
from simgen.coverage.summary import (
    PLAYER_FRAME_THRESHOLDS,
    by_distance,
    cell_means,
    in_area,
    nearest_distance,
    share_at_least,
)
from simgen.qa.checks import Check
from simgen.qa.report import Report, Section, Table
from simgen.scan.sensor import Sensor
from simgen.scene.pitch import HALF_LENGTH_M, HALF_WIDTH_M

DPI = 100
LEVELS = (0, 1, 2, 5, 10, 20, 50, 100, 200, 500)  # colour steps of points per player per frame (and more)
MATCH_CELL_M = 5.0  # cells of the match's heatmap
CELL_THRESHOLDS = (1, 5, 20)  # points per frame the report counts cells at


@dataclass(frozen=True)
class RigCoverage:
    """One rig's measurements."""

    name: str  # the scenario's name
    sensors: tuple[Sensor, ...]
    grid: GridCoverage
    match: MatchCoverage | None

    @property
    def sensors_xy_m(self) -> NDArray[np.float64]:
        return np.array([s.origin_m[:2] for s in self.sensors])


@dataclass(frozen=True)
class Target:
    """What a rig must meet: a standing player gets `min_points` per frame on `min_share` of the area's cells."""

    min_points: float
    area: str
    min_share: float  # 0..1


def check(rig: RigCoverage, target: Target) -> Check:
    cells = in_area(rig.grid.grid.centres_m, target.area)
    share = share_at_least(rig.grid.rig_mean[cells], target.min_points)
    return Check(
        rig.name,
        f"standing player >= {target.min_points:g} points per frame, {target.area}",
        f"{100 * share:.1f} % of {int(cells.sum())} cells",
        f">= {100 * target.min_share:g} % of the cells",
        share >= target.min_share,
    )


def _pitch_lines_m() -> list[NDArray[np.float64]]:
    """The painted lines as polylines (N, 2) in metres (those `simgen.view.draw` paints)."""
    from simgen.view.draw import HEADER_PX, Canvas, pitch_lines

    canvas = Canvas((-HALF_LENGTH_M - 1, HALF_LENGTH_M + 1), (-HALF_WIDTH_M - 1, HALF_WIDTH_M + 1), 100.0)
    return [
        np.stack([line[:, 0] / 100.0 + canvas.x_range_m[0], canvas.y_range_m[1] - (line[:, 1] - HEADER_PX) / 100.0], 1)
        for line in pitch_lines(canvas)
    ]


def _heatmap(ax, x_edges: NDArray, y_edges: NDArray, values: NDArray, sensors_xy: NDArray, title: str,
             limits: tuple[float, float, float, float]):
    """Values (X, Y) over the pitch on `ax`, with its lines and the sensors, within limits (x0, x1, y0, y1);
    returns the mesh for a colour bar."""
    norm = BoundaryNorm(LEVELS, plt.get_cmap("viridis").N, extend="max")
    mesh = ax.pcolormesh(x_edges, y_edges, np.ma.masked_invalid(values).T, cmap="viridis", norm=norm)
    for line in _pitch_lines_m():
        ax.plot(line[:, 0], line[:, 1], color="white", linewidth=0.7)
    ax.plot(sensors_xy[:, 0], sensors_xy[:, 1], "r^", markersize=7, markeredgecolor="black")
    ax.set_aspect("equal")
    ax.set_xlim(*limits[:2])
    ax.set_ylim(*limits[2:])
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return mesh


def _limits(sensors_xy: NDArray) -> tuple[float, float, float, float]:
    """The pitch and the sensors (S, 2), with 3 m round them."""
    return (min(-HALF_LENGTH_M, sensors_xy[:, 0].min()) - 3, max(HALF_LENGTH_M, sensors_xy[:, 0].max()) + 3,
            min(-HALF_WIDTH_M, sensors_xy[:, 1].min()) - 3, max(HALF_WIDTH_M, sensors_xy[:, 1].max()) + 3)


def _edges(centres: NDArray, step: float) -> NDArray[np.float64]:
    return np.append(centres - step / 2, centres[-1] + step / 2)


def _grid_edges(grid: GridCoverage) -> tuple[NDArray, NDArray]:
    return _edges(grid.grid.x_m, grid.grid.step_m), _edges(grid.grid.y_m, grid.grid.step_m)


def _save(fig, path: Path) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI)
    plt.close(fig)


def _panels(panels: list[tuple[NDArray, NDArray, NDArray, NDArray, str]], path: Path, label: str) -> None:
    """Heatmaps side by side (two per row): (x edges, y edges, values (X, Y), sensors (S, 2), title) each."""
    columns = min(2, len(panels))
    rows = -(-len(panels) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(6.4 * columns, 4.4 * rows), squeeze=False)
    limits = _limits(np.concatenate([panel[3] for panel in panels]))  # the same in every panel
    mesh = None
    for ax, panel in zip(axes.flat, panels):
        mesh = _heatmap(ax, *panel, limits)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.colorbar(mesh, ax=axes, label=label, shrink=0.8, extend="max")
    _save(fig, path)


def rig_plots(rig: RigCoverage, out_dir: Path) -> tuple[tuple[str, str], ...]:
    """The rig's heatmaps: the rig, each sensor, the match; (path relative to out_dir, caption) each."""
    plots = out_dir / "plots"
    plots.mkdir(exist_ok=True)
    x_edges, y_edges = _grid_edges(rig.grid)
    shape = (len(rig.grid.grid.x_m), len(rig.grid.grid.y_m))
    label = "points per player per frame"
    sensors = rig.sensors_xy_m
    images = []
    _panels([(x_edges, y_edges, rig.grid.rig_mean.reshape(shape), sensors, f"{rig.name}: all sensors")],
            plots / f"{rig.name}_rig.png", label)
    images.append((f"plots/{rig.name}_rig.png", f"{rig.name}: points on a standing player per frame, all sensors"))
    if len(rig.sensors) > 1:
        panels = [(x_edges, y_edges, rig.grid.sensor_mean(i).reshape(shape), sensors[i:i + 1], s.name)
                  for i, s in enumerate(rig.sensors)]
        _panels(panels, plots / f"{rig.name}_sensors.png", label)
        images.append((f"plots/{rig.name}_sensors.png", f"{rig.name}: points on a standing player per frame, "
                                                        "each sensor alone"))
    if rig.match is not None and len(rig.match.rig_points):
        mx = np.arange(-HALF_LENGTH_M, HALF_LENGTH_M + MATCH_CELL_M, MATCH_CELL_M)
        my = np.arange(-HALF_WIDTH_M, HALF_WIDTH_M + MATCH_CELL_M, MATCH_CELL_M)
        values = cell_means(rig.match.position_m, rig.match.rig_points.astype(np.float64), mx, my)
        _panels([(mx, my, values, sensors, f"{rig.name}: the match, {MATCH_CELL_M:g} m cells")],
                plots / f"{rig.name}_match.png", "mean points per labelled player per frame")
        images.append((f"plots/{rig.name}_match.png", f"{rig.name}: the match's players (occlusion included), mean "
                                                      f"points per frame in {MATCH_CELL_M:g} m cells"))
    return tuple(images)


def rigs_plot(rigs: list[RigCoverage], out_dir: Path) -> tuple[str, str]:
    """Every rig's heatmap side by side."""
    panels = []
    for rig in rigs:
        x_edges, y_edges = _grid_edges(rig.grid)
        shape = (len(rig.grid.grid.x_m), len(rig.grid.grid.y_m))
        panels.append((x_edges, y_edges, rig.grid.rig_mean.reshape(shape), rig.sensors_xy_m, rig.name))
    (out_dir / "plots").mkdir(exist_ok=True)
    _panels(panels, out_dir / "plots" / "rigs.png", "points per player per frame")
    return "plots/rigs.png", "the rigs side by side: points on a standing player per frame"


def _percent(share: float) -> str:
    return "-" if np.isnan(share) else f"{100 * share:.1f} %"


def _number(value: float) -> str:
    return "-" if np.isnan(value) else f"{value:g}"


def comparison_table(rigs: list[RigCoverage], target: Target) -> Table:
    """One row per rig: shares of the pitch and of the paper's box, shares of the match's player-frames."""
    header = ["rig", "sensors"]
    header += [f"pitch >= {n}" for n in CELL_THRESHOLDS] + [f"paper box >= {n}" for n in CELL_THRESHOLDS]
    header += [f"match >= {n}" for n in PLAYER_FRAME_THRESHOLDS] + ["verdict"]
    rows = []
    for rig in rigs:
        centres = rig.grid.grid.centres_m
        row = [rig.name, str(len(rig.sensors))]
        for area in ("pitch", "paper"):
            cells = in_area(centres, area)
            row += [_percent(share_at_least(rig.grid.rig_mean[cells], n)) for n in CELL_THRESHOLDS]
        match = rig.match.rig_points if rig.match is not None else np.zeros(0)
        row += [_percent(share_at_least(match, n)) for n in PLAYER_FRAME_THRESHOLDS]
        row.append(check(rig, target).verdict)
        rows.append(tuple(row))
    return Table(tuple(header), tuple(rows))


def distance_table(rig: RigCoverage) -> Table:
    """The issue's table: median points per player per frame and the share with none, per 10 m of distance to
    the nearest sensor, for the standing grid (every heading) and the match."""
    grid_distance = nearest_distance(rig.grid.grid.centres_m, rig.sensors_xy_m)
    headings = len(rig.grid.headings_deg)
    rig_points = rig.grid.points.sum(axis=2)  # (C, K)
    top = float(grid_distance.max())
    standing = by_distance(np.repeat(grid_distance, headings), rig_points.reshape(-1), top)
    bins = [standing]
    names = ["standing"]
    if rig.match is not None:
        bins.append(by_distance(np.minimum(rig.match.distance_m, top), rig.match.rig_points, top))
        names.append("match")
    header = ("", *(f"{lo:g}-{lo + 10:g} m" for lo in standing.lower_m))
    rows = []
    for name, b in zip(names, bins):
        rows.append((f"{name}: median points per player per frame", *map(_number, b.median)))
        rows.append((f"{name}: players with no point", *map(_percent, b.none)))
        rows.append((f"{name}: player-frames", *(str(c) for c in b.count)))
    return Table(header, tuple(rows))


def write_csv(rig: RigCoverage, path: Path) -> None:
    """One row per cell: centre, distance to the nearest sensor, the rig's mean and fewest points over headings,
    each sensor's mean."""
    centres = rig.grid.grid.centres_m
    distance = nearest_distance(centres, rig.sensors_xy_m)
    fewest = rig.grid.points.sum(axis=2).min(axis=1)
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["x_m", "y_m", "distance_m", "rig_mean", "rig_min", *(f"{s.name}_mean" for s in rig.sensors)])
        sensor_means = [rig.grid.sensor_mean(i) for i in range(len(rig.sensors))]
        for c in range(len(centres)):
            writer.writerow([f"{centres[c, 0]:g}", f"{centres[c, 1]:g}", f"{distance[c]:.2f}",
                             f"{rig.grid.rig_mean[c]:.3f}", str(fewest[c]),
                             *(f"{m[c]:.3f}" for m in sensor_means)])


def write_match_csv(match: MatchCoverage, path: Path) -> None:
    """One row per player-frame of the match: where the player stood, distance to the nearest sensor, points of
    the rig and of each sensor."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["x_m", "y_m", "distance_m", "points", *(f"{name}_points" for name in match.sensor_names)])
        for position, distance, rig, points in zip(match.position_m, match.distance_m, match.rig_points,
                                                   match.points):
            writer.writerow([f"{position[0]:.2f}", f"{position[1]:.2f}", f"{distance:.2f}", str(rig),
                             *map(str, points)])


def coverage_report(rigs: list[RigCoverage], target: Target, out_dir: Path) -> Report:
    """Plots and CSVs written into out_dir; the report's page to write with `simgen.qa.report.write_report`."""
    checks = tuple(check(rig, target) for rig in rigs)
    grid = rigs[0].grid
    headings = ", ".join(f"{h:g}" for h in grid.headings_deg)
    sections = [
        Section(
            "Rigs side by side",
            f"A standing player alone at every {grid.grid.step_m:g} m cell, headings {headings} deg, rendered with "
            "each scenario's sensors, scan, noise and goals; the value is the mean over headings of the points of "
            "one frame. 'match': every labelled player (officials aside) of the scenario's own match, rendered as "
            "simgen generate renders it, occlusion included. Shares of cells and of player-frames at least N points.",
            (rigs_plot(rigs, out_dir),),
            (comparison_table(rigs, target),),
        )
    ]
    for rig in rigs:
        write_csv(rig, out_dir / f"{rig.name}.csv")
        match = ""
        if rig.match is not None:
            write_match_csv(rig.match, out_dir / f"{rig.name}_match.csv")
            match = (f" The match: {rig.match.clips} clip(s) x {rig.match.frames} frames, "
                     f"{len(rig.match.rig_points)} player-frames: {rig.name}_match.csv.")
        sections.append(Section(
            f"Rig {rig.name}",
            f"{len(rig.sensors)} sensor(s): " + "; ".join(
                f"{s.name} ({s.preset}) at ({s.pose[0]:g}, {s.pose[1]:g}, {s.pose[2]:g}) m" for s in rig.sensors
            ) + f". Cells: {rig.name}.csv.{match} Distance: to the nearest sensor, horizontal.",
            rig_plots(rig, out_dir),
            (distance_table(rig),),
        ))
    subject = (f"{len(rigs)} rig(s), target: a standing player gets >= {target.min_points:g} points per frame on "
               f">= {100 * target.min_share:g} % of the {target.area} area's cells")
    return Report("simgen coverage", subject, checks, tuple(sections))
