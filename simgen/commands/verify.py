"""`simgen verify`: a dataset's checksums, schema version and label sanity; exit 0 or 1."""

from __future__ import annotations

from pathlib import Path

from simgen.commands.arguments import add_command, add_dataset_argument


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "verify",
        "check a dataset: sha256 of every file, schema version, label sanity",
        "Check a dataset that simgen wrote: every file of manifest.json present with its size and "
        "sha256, no file it does not list, the schema version (manifest and Parquet tables), frame "
        "and clip totals, every shot accounted for, and the labels: boxes finite, human-sized, on "
        "the pitch and standing on or above the ground; stored point counts equal to the points "
        "of each humanoid and to those inside its box; track ids unique per frame, without gaps "
        "or jumps. Each problem is one line `FILE:ROW: problem` (ROW: line number from 1 in a "
        "text label file, row index from 0 in a Parquet table; no ROW for a whole file). Exit "
        "code 0: no problem; 1: problems; 2: not a readable dataset.",
    )
    add_dataset_argument(parser)
    parser.add_argument(
        "--tolerances", type=Path, metavar="FILE", help="edited copy of simgen/qa/tolerances.yaml (labels section)"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from simgen.qa.checks import plural
    from simgen.qa.integrity import verify_dataset
    from simgen.qa.tolerances import load_tolerances

    tolerances = load_tolerances(args.tolerances)
    result = verify_dataset(args.dataset, tolerances.labels)
    for problem in result.problems:
        print(problem)
    for note in result.notes:
        print(f"note: {note}")
    counts = f"{result.files} files, {result.frames} frames, {result.boxes} boxes checked"
    if result.problems:
        print(f"{args.dataset}: {plural(len(result.problems), 'problem')} ({counts})")
        return 1
    print(f"{args.dataset}: ok ({counts})")
    return 0
