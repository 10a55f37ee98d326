"""A whole QA report: of a sensor preset's scan pattern, or of a dataset (its sensors' patterns,
its frames, its humanoids' points and its integrity); plots in REPORT_DIR/plots/."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

import scan_patterns as sp
from simgen.datasets.reader import Dataset
from simgen.labels.statistics import summary_rows
from simgen.qa import plots
from simgen.qa.checks import Check
from simgen.qa.dataset import DatasetQA, dataset_qa
from simgen.qa.integrity import Verification, verify_dataset
from simgen.qa.pattern import HeadQA, sensor_qa
from simgen.qa.report import Report, Section, Table
from simgen.qa.tolerances import Tolerances

PLOTS = "plots"
MAX_PROBLEMS_SHOWN = 50
RANGE_BINS_M = (0, 20, 40, 60, 80, 100, 150)


def _heads_columns(heads: list[HeadQA]) -> tuple[str, ...]:
    return tuple(h.subject for h in heads)


def coverage_table(heads: list[HeadQA]) -> Table:
    first = heads[0].comparison
    rows = []
    for cell in first.coverage:
        for k, t in enumerate(first.times_s):
            mine = [h.comparison.coverage[cell][0][k] for h in heads]
            ref = first.coverage[cell][1][k]
            worst = max((m - ref for m in mine), key=abs) * 100
            rows.append((f"{cell:g}", f"{t:g}", *(f"{m:.2%}" for m in mine), f"{ref:.2%}", f"{worst:+z.2f}"))
    return Table(
        ("cell, deg", "T, s", *_heads_columns(heads), f"official {heads[0].reference}", "largest difference, points"),
        tuple(rows),
    )


def radial_table(heads: list[HeadQA]) -> Table:
    ref = heads[0].comparison.radial[1]
    rows = []
    for k, rho in enumerate(ref.off_axis_deg):
        mine = [h.comparison.radial[0].shots_per_sr_s[k] for h in heads]
        worst = (
            max((m / ref.shots_per_sr_s[k] - 1 for m in mine), key=abs) if ref.shots_per_sr_s[k] > 0 else float("nan")
        )
        rows.append((f"{rho:g}", *(f"{m:,.0f}" for m in mine), f"{ref.shots_per_sr_s[k]:,.0f}", f"{worst:+z.2%}"))
    return Table(("off-axis, deg", *_heads_columns(heads), f"official {heads[0].reference}", "largest difference"),
                 tuple(rows))


def target_table(heads: list[HeadQA]) -> Table:
    first = heads[0].comparison
    rows = tuple(
        (
            f"{r:g} m, {off:g} deg",
            *(f"{h.comparison.target_points[0][k]:.2f}" for h in heads),
            f"{first.target_points[1][k]:.2f}",
        )
        for k, (r, off) in enumerate(first.targets)
    )
    return Table(("target", *_heads_columns(heads), f"official {heads[0].reference}"), rows)


def pattern_sections(name: str, heads: list[HeadQA], out_dir: Path, tol: Tolerances) -> list[Section]:
    """Plots and tables of one sensor's heads; files named after `name`."""
    (out_dir / PLOTS).mkdir(parents=True, exist_ok=True)
    slug = re.sub(r"[^A-Za-z0-9_.-]", "_", name)  # a scenario's own sensor names can hold anything
    image = {kind: f"{PLOTS}/{kind}_{slug}.png" for kind in ("pattern", "coverage", "radial", "targets")}
    plots.shot_patterns(heads, out_dir / image["pattern"])
    sections = [
        Section(
            f"{name}: shot pattern",
            "One 10 Hz frame and 0.5 s of each head, in the head frame, and "
            "the official file's, as in the paper's Fig. 5a.",
            ((image["pattern"], f"{name} shot pattern"),),
        )
    ]
    by_reference: dict[str, list[HeadQA]] = {}
    for h in heads:
        if h.reference is not None:
            by_reference.setdefault(h.reference, []).append(h)
    if not by_reference:
        return sections
    compared = [h for group in by_reference.values() for h in group]
    plots.coverage(compared, out_dir / image["coverage"])
    plots.radial_density(compared, out_dir / image["radial"], tol.pattern.radial_density_rel)
    plots.target_points(compared, out_dir / image["targets"])
    window = "Each head over (0, 4] s of its own clock (its time_offset_s ahead) against Livox's 4 s file."
    sections += [
        Section(
            f"{name}: coverage against integration time",
            window,
            ((image["coverage"], f"{name} coverage"),),
            tuple(coverage_table(group) for group in by_reference.values()),
        ),
        Section(
            f"{name}: radial density",
            "Shots per steradian per second in 0.5 deg off-axis rings.",
            ((image["radial"], f"{name} radial density"),),
            tuple(radial_table(group) for group in by_reference.values()),
        ),
        Section(
            f"{name}: points on a person-sized target",
            "Mean points per 10 Hz frame on an upright 0.5 x 1.8 m "
            "target facing the head, and how often a frame puts no point on it at all.",
            ((image["targets"], f"{name} target points"),),
            tuple(target_table(group) for group in by_reference.values()),
        ),
    ]
    return sections


def pattern_report(preset: str, tol: Tolerances, out_dir: Path) -> Report:
    """Every head of a sensor preset against its official file."""
    sensor = sp.get_sensor(preset)
    heads = sensor_qa(preset, sensor.heads, tol.pattern)
    checks = tuple(c for h in heads for c in h.checks)
    return Report(f"Scan-pattern QA: {preset}", f"{sensor.description}; tolerances from {tol.source}.", checks,
                  tuple(pattern_sections(preset, heads, out_dir, tol)))


def _humanoid_table(qa: DatasetQA) -> Table:
    h = qa.humanoids
    rows = []
    for lo, hi in zip(RANGE_BINS_M[:-1], RANGE_BINS_M[1:]):
        for label, mask in (("in a head's FOV", h.in_fov), ("outside every FOV", ~h.in_fov)):
            chosen = h.points[(h.range_m >= lo) & (h.range_m < hi) & mask]
            if len(chosen):
                rows.append(
                    (f"{lo}-{hi} m", label, f"{len(chosen):,}", f"{np.median(chosen):g}", f"{(chosen == 0).mean():.1%}")
                )
    return Table(("range", "box centre", "samples", "median points", "with no point"), tuple(rows))


def _frames_table(qa: DatasetQA) -> Table:
    c = qa.counts
    rows = [("points per frame", f"{c.points.mean():,.0f}", f"{c.points.min():,}", f"{c.points.max():,}")]
    if c.shots is not None:
        for name, values in (("shots per frame", c.shots), ("dropped, % of shots", c.dropped / c.shots * 100),
                             ("missed, % of shots", c.missed / c.shots * 100)):
            rows.append((name, f"{values.mean():z,.2f}", f"{values.min():z,.2f}", f"{values.max():z,.2f}"))
    return Table(("per frame", "mean", "min", "max"), tuple(rows))


def _in_dataset(file: str, root: Path) -> str:
    """A problem's file as the report names it: from the dataset's folder name down, never its full path."""
    path = Path(file)
    return f"{root.resolve().name}/{path.relative_to(root).as_posix()}" if path.is_relative_to(root) else path.name


def _integrity_section(result: Verification, root: Path) -> Section:
    rows = tuple((_in_dataset(p.file, root), "" if p.row is None else str(p.row), p.message)
                 for p in result.problems[:MAX_PROBLEMS_SHOWN])
    more = len(result.problems) - len(rows)
    text = (f"simgen verify: {len(result.problems)} problems in {result.files} files, {result.frames} frames, "
            f"{result.boxes} boxes" + (f" ({more} more not shown)" if more > 0 else "") + ". " + " ".join(result.notes))
    return Section("Integrity (simgen verify)", text, (), (Table(("file", "row", "problem"), rows),) if rows else ())


def dataset_report(dataset: Dataset, tol: Tolerances, out_dir: Path, max_frames: int) -> Report:
    """The dataset's sensors' patterns, its frames, its humanoids' points and its integrity."""
    manifest = dataset.manifest
    qa = dataset_qa(dataset, tol.dataset, tol.labels, max_frames)  # first: a refused frame leaves nothing written
    verification = verify_dataset(dataset.root, tol.labels)
    checks: list[Check] = []
    sections: list[Section] = []
    for preset, sensor in {s.preset: s for s in manifest.sensors}.items():
        heads = sensor_qa(preset, sensor.heads, tol.pattern)
        checks += [c for h in heads for c in h.checks]
        sections += pattern_sections(preset, heads, out_dir, tol)
    checks += qa.checks
    problems = len(verification.problems)
    checks.append(Check("dataset", "integrity (simgen verify)", f"{problems} problems", "0 problems", problems == 0))
    plots.humanoid_points(qa, out_dir / PLOTS / "humanoids.png")
    plots.frame_statistics(qa, out_dir / PLOTS / "frames.png")
    counted = ("points counted by their track id, per sensor" if dataset.plugin.carries.point_fields else
               f"points counted inside the box grown by {tol.labels.box_margin_m:g} m, credited to the nearest sensor")
    sensors = "; ".join(
        f"{s.name} ({s.preset}) at ({s.origin_m[0]:g}, {s.origin_m[1]:g}, {s.origin_m[2]:g}) m" for s in qa.sensors
    )
    sections += [
        Section(
            "Points per humanoid against range and off-axis angle",
            f"From the boxes of {qa.frames_sampled} of {qa.frames_total} frames; {counted}. Sensors: {sensors}. A "
            "humanoid far off a head's axis, or outside every field of view, can get no point at all in a frame.",
            ((f"{PLOTS}/humanoids.png", "points per humanoid"),),
            (_humanoid_table(qa),),
        ),
        Section(
            "Frames: points, dropout, misses, intensity",
            "",
            ((f"{PLOTS}/frames.png", "frame statistics"),),
            (_frames_table(qa),),
        ),
        Section(
            "Labels: how boxes change from frame to frame, and their points",
            "Every clip's boxes as the dataset was written (manifest.json `labels`; pairs of consecutive frames of a "
            "track, none across a placement).",
            (),
            (
                Table(
                    ("quantity", "median", "90th percentile", "99th percentile"), tuple(summary_rows(manifest.labels))
                ),
            ),
        ),
        _integrity_section(verification, dataset.root),
    ]
    scenario = manifest.scenario.get("name", "?")
    subject = (
        f"{dataset.root.resolve().name}: {manifest.format}, scenario '{scenario}', seed {manifest.seed}, "
        f"{len(manifest.clips)} clips, "
        f"{len(dataset)} frames; tolerances from {tol.source}."
    )
    return Report(f"Dataset QA: {dataset.root.resolve().name}", subject, tuple(checks), tuple(sections))
