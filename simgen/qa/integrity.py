"""`simgen verify`: a dataset's files against its manifest (present, size, sha256, nothing unlisted),
its schema version (manifest.json and every Parquet table), its bookkeeping (frame and clip totals,
every shot accounted for) and its labels (`simgen.qa.label_checks`), each problem at a file and row.
What differs by format (the checks inside its files, where a box is stored, what it cannot carry) the
format's plug-in says (`simgen.datasets.formats`).

A missing directory or an unreadable manifest is bad input (`UserError`), not a problem found.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from simgen.datasets.manifest import MANIFEST_NAME, MAX_MANIFEST_BYTES, ClipEntry, read_manifest
from simgen.datasets.reader import Dataset
from simgen.datasets.schema import SCHEMA_VERSION
from simgen.datasets.verify import Problem
from simgen.datasets.write import CARD_NAME  # describes the manifest, so not listed in it
from simgen.errors import UserError
from simgen.qa.label_checks import box_problems, count_problems, track_problems
from simgen.qa.tolerances import LabelTolerances
from simgen.validation import read_limited


@dataclass(frozen=True)
class Verification:
    problems: tuple[Problem, ...]
    files: int  # files listed in the manifest
    frames: int  # frames whose labels were checked
    boxes: int
    notes: tuple[str, ...]  # checks the format cannot have, clips not read


def schema_problem(root: Path) -> Problem | None:
    """A manifest of another schema version (any other unreadable manifest is left to `read_manifest`)."""
    path = root / MANIFEST_NAME
    try:
        data = json.loads(read_limited(path, "manifest", MAX_MANIFEST_BYTES))
    except (UserError, ValueError, RecursionError):  # left to `read_manifest` to say
        return None
    if isinstance(data, dict) and data.get("schema_version") != SCHEMA_VERSION:
        return Problem(
            str(path), None, f"schema version {data.get('schema_version')}, this simgen reads {SCHEMA_VERSION}"
        )
    return None


def file_problems(dataset: Dataset) -> list[Problem]:
    """Listed files missing or changed, files not listed, and what the format finds inside its files
    (Parquet: tables of another schema)."""
    root, problems = dataset.root, []
    for relative in sorted(dataset.files.records):
        path = root / relative
        try:
            dataset.files.path(relative)
        except UserError as error:
            problems.append(Problem(str(path), None, str(error).removeprefix(f"{path}: ")))
            continue
        inside = dataset.plugin.file_problem(path, relative)
        if inside:
            problems.append(Problem(str(path), None, inside))
    listed = set(dataset.files.records) | {MANIFEST_NAME, CARD_NAME}
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        if path.relative_to(root).as_posix() not in listed:
            problems.append(
                Problem(str(path), None, "not listed in manifest.json (readers that glob the folders would read it)")
            )
    return problems


def clip_problems(dataset: Dataset, entry: ClipEntry, tol: LabelTolerances) -> tuple[list[Problem], int]:
    """Label and bookkeeping problems of one clip whose files are verified; and its box count."""
    first_row: dict[int, int] = {}
    locate = dataset.plugin.locator(dataset.root, entry, first_row)
    frame_rate_hz = dataset.manifest.sensors[0].frame_rate_hz
    problems, tracks, sizes, rows = [], [], [], 0
    before, frame = None, dataset.frame(entry.clip, 0) if entry.frames else None
    for index in range(entry.frames):
        after = dataset.frame(entry.clip, index + 1) if index + 1 < entry.frames else None
        first_row[index] = rows
        rows += len(frame.boxes)
        sizes.append((len(frame.points_m), len(frame.boxes)))
        problems += box_problems(frame, locate, tol)
        if frame.num_points is not None:
            problems += count_problems(frame, locate, 0.5 / frame_rate_hz, tol, before, after)
        if frame.track_id is not None:
            tracks.append((index, frame.track_id, frame.boxes, frame.discontinuity))
        before, frame = frame, after
    if tracks:
        problems += track_problems(tracks, locate, frame_rate_hz, tol)
    problems += dataset.plugin.clip_problems(dataset.files, entry, sizes)
    manifest = str(dataset.root / MANIFEST_NAME)
    points = sum(p for p, _ in sizes)
    if points != entry.points:
        problems.append(
            Problem(manifest, None, f"clip {entry.clip} lists {entry.points} points, its frames hold {points}")
        )
    if rows != entry.boxes:
        problems.append(Problem(manifest, None, f"clip {entry.clip} lists {entry.boxes} boxes, its labels hold {rows}"))
    return problems, rows


def verify_dataset(root: str | Path, tol: LabelTolerances) -> Verification:
    """Every check of `simgen verify` on the dataset at `root`."""
    root = Path(root)
    problem = schema_problem(root)
    if problem is not None:
        return Verification((problem,), 0, 0, 0, ("nothing else checked: the dataset has another schema version",))
    manifest = read_manifest(root)
    dataset = Dataset(root, manifest)
    problems = file_problems(dataset)
    bad = {p.file for p in problems}
    notes, frames, boxes = [], 0, 0
    for entry in manifest.clips:
        if any(str(root / f) in bad for f in dataset.plugin.clip_files(entry)):
            notes.append(f"clip {entry.clip}: labels not checked, its files have problems")
            continue
        try:
            found, count = clip_problems(dataset, entry, tol)
        except UserError as error:  # a file that passed its checksum but does not read
            file, _, message = str(error).partition(": ")
            problems.append(Problem(file, None, message))
            continue
        problems += found
        frames, boxes = frames + entry.frames, boxes + count
    if not dataset.plugin.carries.point_counts:
        notes.append(f"stored point counts: not checked, {manifest.format} stores none")
    if not dataset.plugin.carries.track_ids:
        notes.append(f"track ids: not checked, {manifest.format} stores none")
    return Verification(tuple(problems), len(manifest.files), frames, boxes, tuple(notes))
