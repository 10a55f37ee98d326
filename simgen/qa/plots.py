"""The report's figures, drawn headless (matplotlib's Agg backend) and written as PNG.

Every function takes the numbers of `simgen.qa.pattern` or `simgen.qa.dataset` and a path.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from scan_patterns import HeadSpec
from simgen.atomic import atomic_path
from simgen.qa.dataset import DatasetQA
from simgen.qa.pattern import ACCUMULATED_S, FRAME_S, TARGET_AT_M, TARGET_OFF_AXIS_DEG, TARGET_RANGES_M, HeadQA, window

DPI = 100
REFERENCE_STYLE = {"color": "black", "linestyle": "--", "linewidth": 1.6}


def fit_titles(fig) -> None:
    """Wrap the figure's titles (its own, `fig.texts`, and its axes') at spaces until each lies inside the figure."""
    fig.canvas.draw()  # lays the figure out, so that the titles stand where they will be drawn
    renderer = fig.canvas.get_renderer()
    right = fig.bbox.width
    for text in [*fig.texts, *(ax.title for ax in fig.axes)]:
        lines: list[str] = []
        for word in text.get_text().split(" "):
            candidate = [*lines[:-1], f"{lines[-1]} {word}"] if lines else [word]
            text.set_text("\n".join(candidate))
            extent = text.get_window_extent(renderer)
            lines = candidate if (extent.x0 >= 0 and extent.x1 <= right) or not lines else [*lines, word]
        text.set_text("\n".join(lines))


def _save(fig, path: Path) -> None:
    fit_titles(fig)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI)
    plt.close(fig)


def _references(heads: list[HeadQA]) -> dict[str, HeadQA]:
    """One head per official file, to draw that file once."""
    return {h.reference: h for h in reversed(heads) if h.reference is not None}


def _pattern_panel(ax, uv: np.ndarray, head: HeadSpec, title: str) -> None:
    ax.scatter(uv[:, 0], uv[:, 1], s=0.2, c=np.arange(len(uv)), cmap="viridis", linewidths=0, rasterized=True)
    az_lo, az_hi, el_lo, el_hi = head.extent_deg
    if head.fov_box_deg is None:
        ax.add_patch(plt.Circle((0, 0), head.fov_deg / 2, fill=False, color="grey", linewidth=0.8))
        ax.set_xlabel("off-axis angle towards +y (left), deg")
        ax.set_ylabel("off-axis angle towards +z (up), deg")
    else:
        ax.add_patch(
            plt.Rectangle((az_lo, el_lo), az_hi - az_lo, el_hi - el_lo, fill=False, color="grey", linewidth=0.8)
        )
        ax.set_xlabel("azimuth (+ left), deg")
        ax.set_ylabel("elevation (+ up), deg")
    ax.set_aspect("equal")
    ax.set_xlim(az_hi + 1, az_lo - 1)  # +y (left) on the left: seen from behind the head
    ax.set_ylim(el_lo - 1, el_hi + 1)
    ax.set_title(title, fontsize=10)


def shot_patterns(heads: list[HeadQA], path: Path) -> None:
    """Each head's shots in one 10 Hz frame and in 0.5 s, and each official file's, head frame."""
    rows = [(h.subject, h.shots, h.head) for h in heads]
    rows += [(f"official {name}", h.reference_shots, h.head) for name, h in _references(heads).items()]
    fig, axes = plt.subplots(len(rows), 2, figsize=(10, 4.8 * len(rows)), squeeze=False, layout="constrained")
    for (name, shots, head), row in zip(rows, axes):
        for ax, seconds in zip(row, (FRAME_S, ACCUMULATED_S)):
            uv = window(shots, seconds, head.field_of_view)
            _pattern_panel(ax, uv, head, f"{name}: {seconds:g} s, {len(uv):,} shots")
    fig.suptitle(
        "Shot pattern seen from behind the head (cones: azimuthal-equidistant; boxes: azimuth and elevation; colour: "
        "time, dark = early)"
    )
    _save(fig, path)


def coverage(heads: list[HeadQA], path: Path) -> None:
    """Coverage against integration time per cell size: heads and official files."""
    compared = [h for h in heads if h.comparison is not None]
    cells = list(compared[0].comparison.coverage)
    fig, axes = plt.subplots(1, len(cells), figsize=(5 * len(cells), 4.2), squeeze=False, layout="constrained")
    for ax, cell in zip(axes[0], cells):
        for h in compared:
            ax.plot(h.comparison.times_s, h.comparison.coverage[cell][0] * 100, marker="o", label=h.subject)
        for name, h in _references(compared).items():
            ax.plot(
                h.comparison.times_s, h.comparison.coverage[cell][1] * 100, label=f"official {name}", **REFERENCE_STYLE
            )
        ax.set_xscale("log")
        ax.set_ylim(0, 102)
        ax.set_xlabel("integration time T, s")
        ax.set_ylabel("field of view covered, %")
        ax.set_title(f"{cell:g} deg cells")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Coverage: share of the field of view's cells hit at least once within T")
    _save(fig, path)


def radial_density(heads: list[HeadQA], path: Path, tolerance_rel: float) -> None:
    """Shots per solid angle and second against off-axis angle, and the relative difference."""
    compared = [h for h in heads if h.comparison is not None]
    fig, (top, bottom) = plt.subplots(
        2, 1, figsize=(9, 7.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]}, layout="constrained"
    )
    for h in compared:
        mine, ref = h.comparison.radial
        top.plot(mine.off_axis_deg, mine.shots_per_sr_s, label=h.subject)
        with np.errstate(divide="ignore", invalid="ignore"):
            bottom.plot(mine.off_axis_deg, (mine.shots_per_sr_s / ref.shots_per_sr_s - 1) * 100, label=h.subject)
    for name, h in _references(compared).items():
        ref = h.comparison.radial[1]
        top.plot(ref.off_axis_deg, ref.shots_per_sr_s, label=f"official {name}", **REFERENCE_STYLE)
    top.set_yscale("log")
    top.set_ylabel("shots per sr per s")
    top.set_title(
        "Radial density: shots per solid angle and second in 0.5 deg rings (cones) or elevation bands (boxes)"
    )
    top.legend(fontsize=8)
    top.grid(True, which="both", alpha=0.3)
    bottom.axhspan(-tolerance_rel * 100, tolerance_rel * 100, color="green", alpha=0.12, label="tolerance")
    bottom.axhline(0, color="black", linewidth=0.8)
    bottom.set_xlabel("off-axis angle (cones) or elevation (boxes), deg")
    bottom.set_ylabel("difference from official, %")
    bottom.legend(fontsize=8)
    bottom.grid(True, alpha=0.3)
    _save(fig, path)


def target_points(heads: list[HeadQA], path: Path) -> None:
    """Points per 10 Hz frame on a 0.5 x 1.8 m target against range and off-axis angle."""
    compared = [h for h in heads if h.by_range is not None]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex="col", layout="constrained")
    xs = (np.array(TARGET_RANGES_M), np.array(TARGET_OFF_AXIS_DEG))
    for col, (x, attr) in enumerate(zip(xs, ("by_range", "by_off_axis"))):
        for h in compared:
            curve = getattr(h, attr)[0]
            axes[0, col].plot(x[: len(curve.mean)], curve.mean, marker="o", label=h.subject)
            axes[1, col].plot(x[: len(curve.mean)], curve.zero_share * 100, marker="o", label=h.subject)
        for name, h in _references(compared).items():
            curve = getattr(h, attr)[1]
            axes[0, col].plot(x[: len(curve.mean)], curve.mean, label=f"official {name}", **REFERENCE_STYLE)
            axes[1, col].plot(x[: len(curve.mean)], curve.zero_share * 100, label=f"official {name}", **REFERENCE_STYLE)
        axes[0, col].set_yscale("log")
        axes[0, col].set_ylabel("mean points per frame")
        axes[1, col].set_ylabel("frames with no point, %")
        axes[1, col].set_ylim(-2, 102)
        for ax in axes[:, col]:
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
    axes[0, 0].set_title("on the boresight")
    axes[0, 1].set_title(f"at {TARGET_AT_M:g} m")
    axes[1, 0].set_xlabel("range, m")
    axes[1, 1].set_xlabel("off-axis angle, deg")
    fig.suptitle("Points per 10 Hz frame on an upright 0.5 x 1.8 m target facing the head")
    _save(fig, path)


def _binned(x: np.ndarray, y: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bin centres, median of y and share of y == 0 per bin (NaN where a bin is empty)."""
    which = np.digitize(x, edges) - 1
    median, zero = np.full(len(edges) - 1, np.nan), np.full(len(edges) - 1, np.nan)
    for b in range(len(edges) - 1):
        values = y[which == b]
        if len(values):
            median[b], zero[b] = np.median(values), (values == 0).mean() * 100
    return (edges[1:] + edges[:-1]) / 2, median, zero


def humanoid_points(qa: DatasetQA, path: Path) -> None:
    """Points per humanoid and frame against range and off-axis angle, from the dataset's boxes."""
    h = qa.humanoids
    fig, axes = plt.subplots(
        2, 2, figsize=(12, 8), sharex="col", gridspec_kw={"height_ratios": [2, 1]}, layout="constrained"
    )
    panels = (
        (h.range_m, h.off_axis_deg, "range from the sensor, m", "off-axis angle, deg", 5.0),
        (h.off_axis_deg, h.range_m, "off-axis angle from the nearest head's boresight, deg", "range, m", 2.0),
    )
    for col, (x, colour, xlabel, clabel, step) in enumerate(panels):
        top, bottom = axes[0, col], axes[1, col]
        points = h.points + np.random.default_rng(0).uniform(-0.2, 0.2, len(h.points)) * (h.points == 0)
        dots = top.scatter(x, points, c=colour, s=6, cmap="viridis", alpha=0.7, linewidths=0)
        fig.colorbar(dots, ax=top, label=clabel)
        edges = step * np.arange(0, (np.max(x) // step if len(x) else 0) + 2)
        centres, median, zero = _binned(x, h.points, edges)
        top.plot(centres, median, color="red", marker="o", label="median per bin")
        top.set_yscale("symlog", linthresh=1)
        top.set_ylabel("points per humanoid and frame")
        top.legend(fontsize=8)
        top.grid(True, which="both", alpha=0.3)
        bottom.bar(centres, zero, width=step * 0.8, color="grey")
        bottom.set_ylabel("with no point, %")
        bottom.set_ylim(0, 100)
        bottom.set_xlabel(xlabel)
        bottom.grid(True, alpha=0.3)
    fig.suptitle(
        f"Points per humanoid: {len(h.points):,} samples from {qa.frames_sampled} frames "
        f"({(h.points == 0).mean():.0%} with no point)"
        if len(h.points)
        else "Points per humanoid: no humanoid"
    )
    _save(fig, path)


def frame_statistics(qa: DatasetQA, path: Path) -> None:
    """Points (and shots) per frame, dropout and misses per frame, and the intensity histogram."""
    c = qa.counts
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), layout="constrained")
    frames = np.arange(len(c.points))
    axes[0].plot(frames, c.points, label="points")
    if c.shots is not None:
        axes[0].plot(frames, c.shots, label="shots")
        axes[1].plot(frames, c.dropped / c.shots * 100, label="dropped (random dropout)")
        axes[1].plot(frames, c.missed / c.shots * 100, label="missed (no return in range)")
        axes[1].set_ylabel("share of shots, %")
        axes[1].legend(fontsize=8)
    else:
        axes[1].text(
            0.5, 0.5, "this format keeps no shot counts", ha="center", va="center", transform=axes[1].transAxes
        )
    axes[0].set_ylabel("per frame")
    axes[0].set_ylim(bottom=0)
    axes[0].legend(fontsize=8)
    axes[0].set_title("Points per frame" + ("" if c.shots is not None else f" ({qa.frames_sampled} sampled frames)"))
    axes[1].set_title("Dropout and misses per frame")
    for ax in axes[:2]:
        ax.set_xlabel("frame (all clips, in order)")
        ax.grid(True, alpha=0.3)
    axes[2].bar(np.arange(256), qa.intensity, width=1.0, color="tab:blue")
    axes[2].set_yscale("log")
    axes[2].set_xlabel("intensity (calibrated reflectivity), 0-255")
    axes[2].set_ylabel("points")
    axes[2].set_title(f"Intensity histogram ({qa.frames_sampled} frames)")
    axes[2].grid(True, alpha=0.3)
    _save(fig, path)
