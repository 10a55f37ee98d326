"""`simgen qa`: a scan-pattern and dataset fidelity report (index.html, report.md, plots) with a
verdict per check; exit code 0 when every check passes, 1 when one fails."""

from __future__ import annotations

import shutil
from pathlib import Path

from simgen.commands.arguments import add_command, add_dataset_argument
from simgen.errors import UserError
from simgen.output_path import check_output

DEFAULT_MAX_FRAMES = 500


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "qa",
        "fidelity report of a scan pattern or a dataset, with pass / fail verdicts",
        "Write a fidelity report to REPORT_DIR: index.html (one self-contained file, plots embedded), report.md and "
        "plots/*.png. --pattern PRESET: each head's shot pattern (one frame and 0.5 s), coverage "
        "against integration time, radial density and points on a person-sized target, against "
        "Livox's official file of the head's type. DATASET: the same for the presets of its "
        "sensors, plus points per humanoid against range and off-axis angle, per-frame points, "
        "dropout and misses, the intensity histogram and `simgen verify`. Each check passes or "
        "fails against tolerances (simgen/qa/tolerances.yaml, or an edited copy given with "
        "--tolerances). Exit code 0: every check passed; 1: a check failed; 2: bad input.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--pattern", metavar="PRESET", help="sensor preset (see `simgen pattern --help`)")
    add_dataset_argument(source, nargs="?")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, metavar="REPORT_DIR", help="report directory (created)"
    )
    parser.add_argument("--tolerances", type=Path, metavar="FILE", help="edited copy of simgen/qa/tolerances.yaml")
    parser.add_argument(
        "--max-frames",
        type=int,
        default=DEFAULT_MAX_FRAMES,
        help=f"frames read for the per-humanoid and intensity plots, spread over the dataset (default "
             f"{DEFAULT_MAX_FRAMES})",
    )
    parser.set_defaults(func=run)


def _print_verdicts(report) -> None:
    from simgen.qa.report import verdict_table

    table = verdict_table(report.checks)
    widths = [max(len(row[i]) for row in (table.header, *table.rows)) for i in range(len(table.header))]
    for row in (table.header, *table.rows):
        print("  ".join(value.ljust(width) for value, width in zip(row, widths)).rstrip())


def run(args) -> int:
    from simgen.qa.tolerances import load_tolerances

    if args.max_frames < 1:
        raise UserError(f"--max-frames must be at least 1, got {args.max_frames}")
    tolerances = load_tolerances(args.tolerances)  # a bad file is one line before the heavy imports below

    from scan_patterns import UnknownSensorError
    from scan_patterns.replay import PatternFileNotFound
    from simgen.datasets import open_dataset
    from simgen.qa.build import dataset_report, pattern_report
    from simgen.qa.checks import exit_code, summary
    from simgen.qa.report import write_report

    out = check_output(args.output, "folder", reads=[] if args.dataset is None else [args.dataset])
    created = not out.exists()
    try:
        if args.pattern is not None:
            out.mkdir(parents=True, exist_ok=True)
            report = pattern_report(args.pattern, tolerances, out)
        else:
            dataset = open_dataset(args.dataset)
            out.mkdir(parents=True, exist_ok=True)
            report = dataset_report(dataset, tolerances, out, args.max_frames)
    except (UserError, UnknownSensorError, PatternFileNotFound) as error:
        if created:  # a refused qa leaves nothing behind
            shutil.rmtree(out, ignore_errors=True)
        raise UserError(str(error)) from None
    write_report(report, out)
    _print_verdicts(report)
    print(f"{summary(list(report.checks))}; report: {out / 'index.html'}")
    return exit_code(report.checks)
