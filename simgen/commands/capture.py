"""`simgen capture`: play a GRF level and write the motion clip (skeletons + ball) to Parquet."""

from __future__ import annotations

import time

from tqdm import tqdm

from simgen.commands.arguments import add_command, add_scenario_arguments
from simgen.errors import UserError
from simgen.output_path import check_output


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "capture",
        "play a football match in the real engine and record every player's skeleton",
        "Play the scenario's Google Research Football level with all 22 players on the "
        "engine's built-in AI and write a motion clip: per frame the game time and the ball, per "
        "humanoid (players, referee, linesmen) a stable track id, team, role and the 12 skeleton "
        "keypoints in metres, in the pitch frame (origin at the centre spot, x towards the right "
        "team's goal, y left, z up).",
    )
    add_scenario_arguments(
        parser, "motion clip to write (.parquet)", "frames to capture (default: the scenario's motion.frames)"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from simgen.motion.clip_io import write_clip
    from simgen.motion.engine import capture_motion, check_level
    from simgen.scenario import load_scenario, parse_scenario

    scenario = load_scenario(args.scenario)
    overrides = {}
    if args.frames is not None:
        overrides["motion"] = {**scenario.motion.model_dump(), "frames": args.frames}
        # nothing is scanned: no frame count to cover
        overrides["scan"] = {**scenario.scan.model_dump(), "frames": None}
    if args.seed is not None:
        overrides["seed"] = args.seed
    if overrides:
        scenario = parse_scenario({**scenario.model_dump(), **overrides}, "command line")
    check_output(args.output, "file", reads=[args.scenario])  # before the engine runs, not after
    if args.output.suffix != ".parquet":
        raise UserError(f"{args.output}: a motion clip is a .parquet file")
    if not args.output.parent.is_dir():
        raise UserError(f"{args.output.parent}: output directory does not exist")
    check_level(scenario.motion.level)

    started = time.perf_counter()
    with tqdm(total=scenario.motion.frames, unit="frame", desc="capture", dynamic_ncols=True) as bar:
        clip = capture_motion(scenario.motion, scenario.seed, progress=bar.update)
    write_clip(clip, args.output)
    seconds = time.perf_counter() - started
    size_kib = args.output.stat().st_size / 1024
    print(
        f"wrote {args.output}: {clip.num_frames} frames at {clip.capture_hz} Hz "
        f"({clip.time_s[-1] - clip.time_s[0]:.1f} s of game time) x {clip.num_humanoids} humanoids "
        f"({', '.join(f'{(clip.team == t).sum()} {t}' for t in ('left', 'right', 'official'))}) "
        f"x 12 keypoints, {size_kib:.0f} KiB, in {seconds:.1f} s"
    )
    return 0
