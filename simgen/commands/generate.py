"""`simgen generate`: a scenario -> a labelled dataset (Parquet, KITTI, KITTI tracking, OpenPCDet or a ROS 2 MCAP bag
per clip)."""

from __future__ import annotations

import os

from tqdm import tqdm

from simgen.commands.arguments import add_command, add_scenario_arguments
from simgen.datasets.formats import FORMATS
from simgen.errors import UserError
from simgen.output_path import check_output


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "generate",
        "make a labelled LiDAR dataset from a scenario",
        "For each clip: play the scenario's match in the football engine, scan it with the "
        "scenario's LiDARs, label every humanoid, and write the frames as they are made (memory does not "
        "grow with a clip's length). A clip is captured once, then its frames are rendered in shards "
        "(--shard-frames); captures and shards run in parallel on this machine's cores (--workers) or as "
        "tasks on a Ray cluster (--executor ray); the same scenario and seed give byte-identical datasets "
        "whatever the executor, workers or shards. An interrupted run is finished with --resume.",
    )
    add_scenario_arguments(
        parser,
        "dataset directory to create, e.g. datasets/NAME",
        "frames per clip (default: the scenario's scan.frames)",
    )
    parser.add_argument("--format", choices=FORMATS, help="dataset layout (default: the scenario's, else parquet)")
    parser.add_argument(
        "--kitti-images",
        action="store_true",
        help="kitti: also write blank placeholder training/image_2 PNGs, as OpenPCDet's KITTI info generation needs",
    )
    parser.add_argument(
        "--density", type=float, help="shots per second as a multiple of the real sensor's (x1, x2, ...)"
    )
    parser.add_argument("--clips", type=int, help="number of clips (default: the scenario's dataset.clips)")
    parser.add_argument(
        "--workers", type=int, default=1, help="local worker processes, one capture or shard each at a time (default 1)"
    )
    parser.add_argument(
        "--executor", choices=("local", "ray"), default="local", help="where captures and shards run (default local)"
    )
    parser.add_argument(
        "--shard-frames",
        type=int,
        default=0,
        help="frames rendered per work unit: a clip's motion is captured once, then its frames are rendered as "
        "shards of this many frames in parallel, each resumable (default 0: automatic, enough shards for every "
        "worker, at most 3000 frames each); the dataset is the same whatever the value",
    )
    parser.add_argument("--address", help="Ray cluster address, e.g. 10.0.0.5:6379 (default: start a local Ray)")
    parser.add_argument(
        "--resume", action="store_true", help="finish an interrupted run, keeping the clips it completed"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing dataset in the output directory")
    parser.set_defaults(func=run)


def _resolve(args):
    from simgen.scenario import load_scenario, parse_scenario

    scenario = load_scenario(args.scenario)
    data = scenario.model_dump()
    if args.format:
        data["dataset"]["format"] = args.format
    if args.kitti_images:
        data["dataset"]["kitti_images"] = True
    if args.clips is not None:
        data["dataset"]["clips"] = args.clips
    if args.density is not None:
        data["scan"]["density"] = args.density
    if args.frames is not None:
        data["scan"]["frames"] = args.frames
        # Capture just enough motion for the frames asked for (plus one sample to interpolate to):
        # `--frames 6000` of a whole match plays 10 minutes, not the match.
        data["motion"]["frames"] = int(args.frames / data["scan"]["frame_rate_hz"] * data["motion"]["capture_hz"] + 2)
    if args.seed is not None:
        data["seed"] = args.seed
    return parse_scenario(data, "command line")


class _Bars:
    """A bar per clip in flight (its engine capture, then its frames), and one for the whole dataset."""

    def __init__(self, clips: int):
        self.clips = clips
        self.total: tqdm | None = None  # opened with the first clip, after the output checks
        self.bars: dict[int, tqdm] = {}

    def __call__(self, event: str, clip_index: int, number: int) -> None:
        if self.total is None:
            self.total = tqdm(total=self.clips, unit="clip", desc="dataset", position=0, dynamic_ncols=True)
        if event in ("capture", "start"):
            self._close(clip_index)
            free = min(set(range(1, len(self.bars) + 2)) - {b.pos for b in self.bars.values()})
            desc, unit = (
                (f"clip_{clip_index:04d} capture", "motion frame")
                if event == "capture"
                else (f"clip_{clip_index:04d}", "frame")
            )
            self.bars[clip_index] = tqdm(
                total=number, unit=unit, desc=desc, position=free, leave=False, dynamic_ncols=True
            )
        elif event in ("captured", "frame") and clip_index in self.bars:
            self.bars[clip_index].update(number)
        elif event == "done":
            self._close(clip_index)
            self.total.update(1)

    def _close(self, clip_index: int) -> None:
        bar = self.bars.pop(clip_index, None)
        if bar:
            bar.close()

    def close(self) -> None:
        for bar in self.bars.values():
            bar.close()
        if self.total is not None:
            self.total.close()


def run(args) -> int:
    from simgen.datasets.formats import dataset_format
    from simgen.pipeline.dataset_run import generate
    from simgen.pipeline.memory import ARROW_ENVIRONMENT

    for name, value in ARROW_ENVIRONMENT.items():  # before Arrow's first allocation; workers inherit it
        os.environ.setdefault(name, value)
    from simgen.motion.engine import check_level

    check_output(args.output, "folder", reads=[args.scenario], replaces=args.overwrite)
    scenario = _resolve(args)
    if args.workers < 1 or args.workers > 4 * (os.cpu_count() or 1):
        raise UserError(f"--workers: {args.workers} is not between 1 and {4 * (os.cpu_count() or 1)}")
    if args.address and args.executor != "ray":
        raise UserError("--address is for --executor ray")
    if args.resume and args.overwrite:
        raise UserError("--resume and --overwrite contradict each other; choose one")
    check_level(scenario.motion.level)
    bars = _Bars(scenario.dataset.clips)
    try:
        totals = generate(
            scenario,
            args.output,
            args.workers,
            args.executor,
            args.address,
            args.resume,
            args.overwrite,
            bars,
            args.shard_frames,
        )
    finally:
        bars.close()
    fmt = scenario.dataset.format
    rate = totals["frames"] / max(totals["seconds"], 1e-9)
    lines = [
        f"dataset   {args.output} ({fmt}, scenario '{scenario.name}', seed {scenario.seed}, density "
        f"x{scenario.scan.density:g})",
        f"clips     {totals['clips']} ({totals['resumed_clips']} kept from the interrupted run)",
        f"frames    {totals['frames']:,}",
        f"points    {totals['points']:,}",
        f"boxes     {totals['boxes']:,}",
        f"files     {totals['files']:,}, {totals['bytes'] / 2**20:,.1f} MiB",
        f"time      {totals['seconds']:.1f} s ({rate:.1f} frames/s)",
        f"read it   python -c \"import simgen.datasets as d; print(d.open('{args.output}'))\"",
    ]
    lines += dataset_format(fmt).summary_lines(str(args.output))
    print("\n".join(lines))
    return 0
