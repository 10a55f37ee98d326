"""`simgen coverage`: how well each scenario's sensor rig sees players over the whole pitch, measured by rendering;
or, with --candidates, the best K mounting positions of one sensor model picked greedily."""

from __future__ import annotations

import shutil
from pathlib import Path

from simgen.commands.arguments import add_command
from simgen.errors import UserError

DEFAULT_STEP_M = 1.0
DEFAULT_HEADINGS = 4
DEFAULT_MIN_POINTS = 5.0
MAX_MATCH_FRAMES = 50_000  # frames of the match over all clips: 1.1 million player-frames kept in memory


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "coverage",
        "coverage of sensor rigs over the pitch: heatmaps, points by distance, a verdict per rig",
        "For each SCENARIO's sensor rig, render (1) a standing player alone at every cell of a grid over the pitch "
        "(--step, default 1 m), in --headings headings, with the scenario's sensors, scan pattern, noise and goals: "
        "points per player per frame at each cell, per sensor and for the rig; and (2) the scenario's own match "
        "(--match-clips clips of --match-frames frames, as `simgen generate` renders them, occlusion included): "
        "points per labelled player per frame by pitch cell and by distance to the nearest sensor, and the shares of "
        "player-frames with at least 1, 5 and 20 points. Writes OUT/index.html (self-contained), OUT/report.md, "
        "OUT/plots/*.png (heatmaps over the pitch per rig and per sensor, the rigs side by side) and OUT/RIG.csv "
        "(a row per cell). Each rig passes when a standing player gets --min-points points per frame on at least "
        "--min-share %% of the --area's cells (pitch: the whole pitch; paper: the paper's [-40, 40] m box). "
        "With --candidates FILE --sensors K and one SCENARIO: render every candidate mounting of the file's one "
        "sensor model alone on the grid, pick K greedily on that target (the share of the --area's cells where a "
        "standing player gets --min-points), write the picked rig as OUT/NAME_pickK.yaml (the SCENARIO with those "
        "sensors) and report it beside the SCENARIO's own rig. "
        "Exit code 0: every rig passes; 1: one does not; 2: bad input.",
    )
    parser.add_argument("scenarios", type=Path, nargs="+", metavar="SCENARIO",
                        help="scenario YAML files (one rig each)")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT", help="report directory (created)")
    parser.add_argument("--step", type=float, default=DEFAULT_STEP_M, metavar="M",
                        help=f"grid step, metres (default {DEFAULT_STEP_M:g})")
    parser.add_argument("--headings", type=int, default=DEFAULT_HEADINGS, metavar="N",
                        help=f"headings of each standing player, evenly spaced (default {DEFAULT_HEADINGS})")
    parser.add_argument("--min-points", type=float, default=DEFAULT_MIN_POINTS, metavar="N",
                        help=f"points per frame a standing player must get (default {DEFAULT_MIN_POINTS:g})")
    parser.add_argument("--min-share", type=float, default=100.0, metavar="PERCENT",
                        help="share of the area's cells that must get them (default 100)")
    parser.add_argument("--area", choices=("pitch", "paper"), default="pitch",
                        help="cells the target applies to: the whole pitch or the paper's [-40, 40] m box")
    parser.add_argument("--match-clips", type=int, default=1, metavar="N",
                        help="clips of the scenario's match to render (default 1; 0: no match)")
    parser.add_argument("--match-frames", type=int, metavar="N",
                        help="frames of each match clip (default: the scenario's frames per clip)")
    parser.add_argument("--candidates", type=Path, metavar="FILE",
                        help="candidate mountings of one sensor model (YAML; see scenarios/candidates/)")
    parser.add_argument("--sensors", type=int, metavar="K", help="sensors to pick from --candidates")
    parser.set_defaults(func=run)


def _check_arguments(args) -> None:
    from simgen.coverage.grid import checked_grid

    checked_grid(args.step, args.headings)
    if not 0 <= args.min_points <= 10_000:
        raise UserError(f"--min-points {args.min_points:g}: must lie in [0, 10000]")
    if not 0 < args.min_share <= 100:
        raise UserError(f"--min-share {args.min_share:g}: must lie in (0, 100]")
    if not 0 <= args.match_clips <= 100:
        raise UserError(f"--match-clips {args.match_clips}: must lie in [0, 100]")
    if args.match_frames is not None and not 1 <= args.match_frames <= 100_000:
        raise UserError(f"--match-frames {args.match_frames}: must lie in [1, 100000]")
    if (args.candidates is None) != (args.sensors is None):
        raise UserError("--candidates and --sensors go together")
    if args.candidates is not None and len(args.scenarios) != 1:
        raise UserError(f"--candidates takes one SCENARIO (the rig's scan, noise and match), got {len(args.scenarios)}")


def _candidates(args) -> tuple:
    """The preset and candidates of --candidates, with --sensors checked against them."""
    from annotated_types import MaxLen

    from simgen.coverage.candidates import load_candidates
    from simgen.scenario import Scenario

    preset, candidates = load_candidates(args.candidates)
    most = next(m.max_length for m in Scenario.model_fields["sensors"].metadata if isinstance(m, MaxLen))
    if not 1 <= args.sensors <= min(len(candidates), most):
        raise UserError(f"--sensors {args.sensors}: must lie in [1, {min(len(candidates), most)}] "
                        f"({len(candidates)} candidates, at most {most} sensors in a scenario)")
    return preset, candidates


def _picked(args, scenario, preset, candidates, headings):
    """The scenario with the sensors picked from the candidates, its YAML written to the report directory."""
    import yaml
    from tqdm import tqdm

    from simgen.atomic import atomic_path
    from simgen.coverage.candidates import pick_rig
    from simgen.coverage.grid import pitch_grid
    from simgen.coverage.summary import in_area

    cells = in_area(pitch_grid(args.step).centres_m, args.area)
    with tqdm(total=len(candidates), unit="candidate", desc="candidates", dynamic_ncols=True) as bar:
        picked = pick_rig(scenario, preset, candidates, args.sensors, args.step, headings, cells, args.min_points,
                          lambda done, total: bar.update(done - bar.n))
    with atomic_path(args.output / f"{picked.name}.yaml") as tmp:
        tmp.write_text(yaml.safe_dump(picked.model_dump(mode="json"), sort_keys=False), encoding="utf-8")
    return picked


def _output_dir(out: Path) -> bool:
    """Create the report directory; whether it was created (then removed again on failure)."""
    from simgen.atomic import check_output_allowed

    check_output_allowed(out)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    return created


def run(args) -> int:
    import numpy as np
    from tqdm import tqdm

    from simgen.coverage.grid import grid_coverage
    from simgen.coverage.match import match_coverage, trimmed
    from simgen.coverage.report import RigCoverage, Target, coverage_report
    from simgen.motion.engine import check_level
    from simgen.qa.checks import exit_code, summary
    from simgen.qa.report import write_report
    from simgen.scan.sensor import scenario_sensors
    from simgen.scenario import load_scenario

    _check_arguments(args)
    scenarios = [load_scenario(path) for path in args.scenarios]
    names = [s.name for s in scenarios]
    for name in names:
        if names.count(name) > 1:
            raise UserError(f"two scenarios are named '{name}': a report names each rig by its scenario's name")
    if args.match_clips:
        for path, scenario in zip(args.scenarios, scenarios):
            try:
                check_level(scenario.motion.level)
            except UserError as error:
                raise UserError(f"{path}: {error}") from None
    for path, scenario in zip(args.scenarios, scenarios):
        frames = args.match_clips * min(args.match_frames or scenario.frames_per_clip(), scenario.frames_per_clip())
        if frames > MAX_MATCH_FRAMES:
            raise UserError(f"{path}: {args.match_clips} match clip(s) of {frames // args.match_clips:,} frames, "
                            f"more than {MAX_MATCH_FRAMES:,} frames in all (lower --match-clips or --match-frames)")
    headings = np.arange(args.headings) * 360.0 / args.headings
    target = Target(args.min_points, args.area, args.min_share / 100)
    if args.candidates is not None:  # a bad file or K is one line before anything is written
        preset, candidates = _candidates(args)
    created = _output_dir(args.output)
    try:
        if args.candidates is not None:
            scenarios.append(_picked(args, scenarios[0], preset, candidates, headings))
        rigs = []
        for scenario in scenarios:
            with tqdm(unit="frame", desc=f"{scenario.name}: standing grid", dynamic_ncols=True) as bar:
                def tick(done: int, total: int, bar=bar) -> None:
                    bar.total = total
                    bar.update(done - bar.n)

                grid = grid_coverage(scenario, args.step, headings, tick)
            match = None
            if args.match_clips:
                cut = trimmed(scenario, args.match_frames or scenario.frames_per_clip())
                with (tqdm(total=args.match_clips * cut.motion.frames, unit="frame", desc=f"{scenario.name}: capture",
                           dynamic_ncols=True) as captured,
                      tqdm(total=args.match_clips * cut.frames_per_clip(), unit="frame",
                           desc=f"{scenario.name}: match", dynamic_ncols=True) as rendered):
                    def count(stage: str, n: int, captured=captured, rendered=rendered) -> None:
                        (captured if stage == "capture" else rendered).update(n)

                    match = match_coverage(cut, args.match_clips, cut.frames_per_clip(), count)
            rigs.append(RigCoverage(scenario.name, scenario_sensors(scenario), grid, match))
        report = coverage_report(rigs, target, args.output)
        write_report(report, args.output)
    except BaseException:
        if created:
            shutil.rmtree(args.output, ignore_errors=True)
        raise
    for c in report.checks:
        print(f"{c.verdict}  {c.subject}: {c.name}: {c.measured} (limit {c.limit})")
    print(f"{summary(list(report.checks))}; report: {args.output / 'index.html'}")
    return exit_code(report.checks)
