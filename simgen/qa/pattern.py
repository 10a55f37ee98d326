"""Scan-pattern fidelity: each head of a sensor preset against Livox's official file of its type.

A head is compared over the official file's window, (0, 4] s of head time or as much as the file
holds (the shipped excerpts: 0.5 s), in its own frame: coverage curves, radial density and points
on a person-sized target (`scan_patterns.metrics`). A head whose kind Livox ships no file for
(`scan_patterns.official_table`) is reported, not failed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import scan_patterns as sp
from scan_patterns.replay import load_pattern_file
from simgen.qa.checks import Check, plural
from simgen.qa.tolerances import PatternTolerances

WINDOW_S = 4.0  # the official files' length
FRAME_S = 0.1  # one 10 Hz frame
ACCUMULATED_S = 0.5
TARGET_RANGES_M = tuple(float(r) for r in range(10, 131, 10))  # on the boresight
TARGET_OFF_AXIS_DEG = tuple(float(a) for a in range(20))  # at TARGET_AT_M
TARGET_AT_M = 50.0


@dataclass(frozen=True)
class TargetCurve:
    """Points per 10 Hz frame on the 0.5 x 1.8 m target: mean and share of frames with none."""

    mean: NDArray[np.float64]
    zero_share: NDArray[np.float64]


@dataclass(frozen=True)
class HeadQA:
    """One head against its official file: shots, metrics and checks."""

    subject: str  # e.g. "mid100-risley head 2"
    head: sp.HeadSpec
    shots: sp.Shots  # head frame, (0, the reference's length or WINDOW_S]
    reference: str | None  # official file name (mid40, avia, ...), None if there is none
    reference_shots: sp.Shots | None
    comparison: sp.PatternComparison | None
    by_range: tuple[TargetCurve, TargetCurve] | None  # head, reference; at TARGET_RANGES_M on axis
    by_off_axis: tuple[TargetCurve, TargetCurve] | None  # head, reference; at TARGET_OFF_AXIS_DEG, TARGET_AT_M
    checks: tuple[Check, ...]


def target_curve(shots: sp.Shots, targets: list[tuple[float, float]]) -> TargetCurve:
    """Mean points per frame and share of frames with no point, per (range m, off-axis deg) target."""
    per_frame = [sp.target_points_per_frame(shots, r, off, 1.0 / FRAME_S) for r, off in targets]
    return TargetCurve(np.array([p.mean() for p in per_frame]), np.array([(p == 0).mean() for p in per_frame]))


def _worst(mine: NDArray, reference: NDArray, relative: bool) -> tuple[int, float]:
    """Index and signed size of the largest |difference| (relative to the reference if asked)."""
    diff = mine - reference
    if relative:
        diff = np.where(reference > 0, diff / np.where(reference > 0, reference, 1.0), np.nan)
    i = int(np.nanargmax(np.abs(diff)))
    return i, float(diff[i])


def pattern_checks(
    subject: str, head: sp.HeadSpec, reference: str, c: sp.PatternComparison, tol: PatternTolerances
) -> list[Check]:
    """Shot rate, coverage per cell size, radial density and target points against the tolerances.

    `measured` gives the largest difference, signed (head minus official), where it is, and both values.
    """
    rate = 1.0 / load_pattern_file(reference).dt_s
    rate_rel = round((head.shots_per_s - rate) / rate, 9) + 0.0  # no -0.00 % from the file's float time steps
    checks = [
        Check(subject, "shot rate", f"{rate_rel:+z.2%} ({head.shots_per_s:,.0f} vs {rate:,.0f} /s)",
              f"<= {tol.shot_rate_rel:.2%}", abs(rate_rel) <= tol.shot_rate_rel)
    ]
    for cell, (a, b) in c.coverage.items():
        i, diff = _worst(a * 100.0, b * 100.0, relative=False)
        checks.append(Check(subject, f"coverage, {cell:g} deg cells",
                            f"{diff:+z.2f} points at T = {c.times_s[i]:g} s ({a[i]:.2%} vs {b[i]:.2%})",
                            f"<= {tol.coverage_points:g} points", abs(diff) <= tol.coverage_points))
    a, b = (p.shots_per_sr_s for p in c.radial)
    i, diff = _worst(a, b, relative=True)
    where = "off-axis" if head.fov_box_deg is None else "elevation"
    checks.append(Check(subject, "radial density", f"{diff:+z.2%} at {c.radial[0].off_axis_deg[i]:g} deg {where}",
                        f"<= {tol.radial_density_rel:.0%}", abs(diff) <= tol.radial_density_rel))
    a, b = c.target_points
    i, diff = _worst(a, b, relative=True)
    r, off = c.targets[i]
    checks.append(Check(subject, "points per frame on a 0.5 x 1.8 m target",
                        f"{diff:+z.2%} at {r:g} m, {off:g} deg ({a[i]:.2f} vs {b[i]:.2f})",
                        f"<= {tol.target_points_rel:.0%}", abs(diff) <= tol.target_points_rel))
    return checks


def head_qa(subject: str, head: sp.HeadSpec, tol: PatternTolerances) -> HeadQA:
    """One head's shots over (0, 4] s, or as long as its official file is, against that file."""
    reference = sp.official_table(head)
    if reference is None:
        shots = sp.head_shots(head, 0.0, WINDOW_S)
        kind = f"{head.fov_deg:g} deg" if head.fov_box_deg is None else f"{head.fov_box_deg} deg box"
        lasers = f" with {plural(head.lasers, 'laser')}" if head.lasers > 1 else ""
        check = Check(subject, "official pattern", f"Livox ships no file for a {kind} head{lasers}", "", None)
        return HeadQA(subject, head, shots, None, None, None, None, None, (check,))
    ref = sp.file_shots(reference)
    shots = sp.head_shots(head, 0.0, min(WINDOW_S, ref.t1_s))
    comparison = sp.compare(shots, ref, head.field_of_view, (subject, f"official {reference}"))
    by_range = [(r, 0.0) for r in TARGET_RANGES_M]
    az_lo, az_hi = head.extent_deg[:2]
    by_angle = [(TARGET_AT_M, a) for a in TARGET_OFF_AXIS_DEG if a < min(-az_lo, az_hi)]
    return HeadQA(
        subject=subject,
        head=head,
        shots=shots,
        reference=reference,
        reference_shots=ref,
        comparison=comparison,
        by_range=(target_curve(shots, by_range), target_curve(ref, by_range)),
        by_off_axis=(target_curve(shots, by_angle), target_curve(ref, by_angle)),
        checks=tuple(pattern_checks(subject, head, reference, comparison, tol)),
    )


def sensor_qa(name: str, heads: Sequence[sp.HeadSpec], tol: PatternTolerances) -> list[HeadQA]:
    """Every head of a sensor, as `<name> head <i>`."""
    return [head_qa(f"{name} head {i}", head, tol) for i, head in enumerate(heads)]


def window(shots: sp.Shots, seconds: float, fov: sp.FieldOfView) -> NDArray[np.float64]:
    """(N, 2) coordinates (degrees) in the projection of `fov` of the shots of the first `seconds`."""
    keep = shots.t_s <= shots.t0_s + seconds + 1e-9
    return sp.field_coords(shots.dirs[keep], fov)
