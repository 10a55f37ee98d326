"""`simgen verify`: a dataset's files against its manifest (present, size, sha256, nothing unlisted),
its schema version (manifest.json and every Parquet table), its bookkeeping (frame and clip totals,
every shot accounted for) and its labels (`simgen.qa.label_checks`), each problem at a file and row.

A missing directory or an unreadable manifest is bad input (`UserError`), not a problem found.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from simgen.datasets import kitti, openpcdet, ros2_bag
from simgen.datasets.manifest import MANIFEST_NAME, MAX_MANIFEST_BYTES, ClipEntry, read_manifest
from simgen.datasets.parquet import open_table, table_path
from simgen.datasets.reader import Dataset, clip_files
from simgen.datasets.schema import SCHEMA_VERSION, TABLES
from simgen.datasets.write import CARD_NAME  # describes the manifest, so not listed in it
from simgen.errors import UserError
from simgen.qa.checks import Problem
from simgen.qa.label_checks import Locate, box_problems, count_problems, track_problems
from simgen.qa.tolerances import LabelTolerances
from simgen.validation import read_limited

TRACKED_FORMATS = ("parquet", "kitti_tracking", "mcap")


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
        return Problem(str(path), None, f"schema version {data.get('schema_version')}, this simgen reads {SCHEMA_VERSION}")
    return None


def file_problems(dataset: Dataset) -> list[Problem]:
    """Listed files missing or changed, files not listed, Parquet tables of another schema."""
    root, problems = dataset.root, []
    for relative in sorted(dataset.files.records):
        path = root / relative
        try:
            dataset.files.path(relative)
        except UserError as error:
            problems.append(Problem(str(path), None, str(error).removeprefix(f"{path}: ")))
            continue
        table = relative.split("/", 1)[0]
        if dataset.format == "parquet" and table in TABLES:
            try:
                open_table(path, table)
            except UserError as error:
                problems.append(Problem(str(path), None, str(error).removeprefix(f"{path}: ")))
    listed = set(dataset.files.records) | {MANIFEST_NAME, CARD_NAME}
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        if path.relative_to(root).as_posix() not in listed:
            problems.append(Problem(str(path), None, "not listed in manifest.json (readers that glob the folders would read it)"))
    return problems


def locator(dataset: Dataset, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
    """Where box i of frame k is stored; `first_row[k]` (boxes before frame k) is filled while reading."""
    root, format, clip_index = dataset.root, dataset.format, entry.clip_index
    if format == "parquet":
        boxes = str(root / table_path("boxes", entry.clip))
        return lambda k, i: (boxes, first_row[k] + i)  # row index, from 0
    if format == "mcap":
        bag = str(root / ros2_bag.bag_path(entry.clip))
        return lambda k, i: (bag, first_row[k] + i)  # box of the clip, from 0, in the /simgen/boxes messages
    if format == "kitti_tracking":
        labels = str(root / kitti.label_path(True, clip_index))
        return lambda k, i: (labels, first_row[k] + i + 1)  # line number, from 1
    if format == "kitti":
        return lambda k, i: (str(root / kitti.label_path(False, clip_index, k)), i + 1)
    return lambda k, i: (str(root / openpcdet.labels_path(clip_index, k)), i + 1)


def frames_table_problems(dataset: Dataset, clip: str, sizes: list[tuple[int, int]]) -> list[Problem]:
    """The Parquet `frames` table against the frames' (points, boxes), and every shot accounted for."""
    path = str(dataset.root / table_path("frames", clip))
    table = open_table(dataset.files.path(table_path("frames", clip)), "frames").read().to_pydict()
    problems = []
    for row, (points, boxes) in enumerate(sizes):
        stored = {name: table[name][row] for name in ("num_points", "num_boxes", "shots", "dropped", "missed")}
        if stored["num_points"] != points:
            problems.append(Problem(path, row, f"num_points is {stored['num_points']}, the frame has {points} points"))
        if stored["num_boxes"] != boxes:
            problems.append(Problem(path, row, f"num_boxes is {stored['num_boxes']}, the frame has {boxes} boxes"))
        returns = stored["shots"] - stored["dropped"] - stored["missed"]
        if returns != stored["num_points"]:
            problems.append(Problem(path, row, f"shots - dropped - missed = {returns}, num_points is {stored['num_points']}"))
    return problems


def clip_problems(dataset: Dataset, entry: ClipEntry, tol: LabelTolerances) -> tuple[list[Problem], int]:
    """Label and bookkeeping problems of one clip whose files are verified; and its box count."""
    first_row: dict[int, int] = {}
    locate = locator(dataset, entry, first_row)
    frame_rate_hz = float(dataset.manifest.sensors[0]["frame_rate_hz"])
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
    if dataset.format == "parquet":
        problems += frames_table_problems(dataset, entry.clip, sizes)
    manifest = str(dataset.root / MANIFEST_NAME)
    points = sum(p for p, _ in sizes)
    if points != entry.points:
        problems.append(Problem(manifest, None, f"clip {entry.clip} lists {entry.points} points, its frames hold {points}"))
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
        if any(str(root / f) in bad for f in clip_files(manifest.format, entry)):
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
    if manifest.format != "parquet":
        notes.append(f"stored point counts: not checked, {manifest.format} stores none")
    if manifest.format not in TRACKED_FORMATS:
        notes.append(f"track ids: not checked, {manifest.format} stores none")
    return Verification(tuple(problems), len(manifest.files), frames, boxes, tuple(notes))
