"""`simgen validate`: check scenario files against the schema without running anything."""

from __future__ import annotations

from pathlib import Path

from simgen.errors import UserError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "validate",
        help="check scenario files (keys, types, ranges, engine level)",
        description="Check each scenario file against simgen's schema: unknown keys, wrong types and "
        "out-of-range values are reported in one line naming the field (exit code 2).",
    )
    parser.add_argument("scenarios", type=Path, nargs="+", metavar="SCENARIO", help="scenario YAML files")
    parser.set_defaults(func=run)


def run(args) -> int:
    from simgen.motion.engine import check_level
    from simgen.scenario import load_scenario

    for path in args.scenarios:
        scenario = load_scenario(path)
        try:
            check_level(scenario.motion.level)
        except UserError as error:
            raise UserError(f"{path}: {error}") from None
        motion = scenario.motion
        print(
            f"{path}: ok (scenario '{scenario.name}', seed {scenario.seed}, level {motion.level}, "
            f"{motion.frames} frames at {motion.capture_hz} Hz)"
        )
    return 0
