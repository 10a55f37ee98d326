"""`simgen-train fit | eval | detect | score | track | study | table2`: the paper's PointPillars tracklet detector
on simgen datasets.

Datasets are read only through simgen.datasets. Bad input (a missing dataset or config, a file
that is not our checkpoint, an option out of range, a model that would not fit in the device's
memory, more loader processes than cores) is one line on stderr and exit code 2, found before
anything is trained or allocated (train.preflight).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
import warnings
from pathlib import Path

import torch
from tqdm import tqdm

import simgen.datasets
from simgen.atomic import atomic_path, check_output_allowed
from simgen.cli import dispatch
from simgen.errors import UserError
from simgen.output_path import check_output
from simgen.scenario import Scenario, load_scenario
from train.checkpoint import load_checkpoint
from train.config import MAX_ITERATIONS, MAX_SEED, MAX_WORKERS, DetectorConfig, load_config, parse_config
from train.detector.inference import detect
from train.detector.model import Detector
from train.evaluation.ap_table import (
    DISTANCE_BIN_M,
    EvalResult,
    evaluate,
    format_ap_table,
    format_distance_table,
    format_zone_table,
    score,
    write_ap_csv,
    write_distance_csv,
    write_zone_csv,
)
from train.fit import fit
from train.preflight import (
    check_memory,
    check_workers,
    dataset_points_per_frame,
    parse_seeds,
    scenario_points_per_frame,
)
from train.study.report import tracking_csv, tracking_markdown, write_tables, zone_csv
from train.study.run import (
    CONFIGS,
    PRESETS,
    SCENARIOS,
    TRACKER_CONFIGS,
    StudyOptions,
    choose_tracklet_filters,
    given_filters,
    model_config,
    module_counts,
    parse_models,
    run_study,
    seed_runs,
    split_window_pairs,
    track,
    tracklet_clip_set,
    tracklet_results,
)
from train.study.seeds import write_seed_tables
from train.study.tracklet_filter import TrackletFilter, read_filters
from train.track.latency import DEFAULT_QUEUE
from train.track.report import metrics_text, write_metrics
from train.track.run import DEFAULT_FILTER, DEFAULT_TRACKER, Model, TrackOptions, run_track
from train.tracking.config import load_tracker_config, load_tracker_configs

SPLITS = ("train", "val", "all")


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors are one line (argparse already exits 2)."""

    def error(self, message: str) -> None:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise UserError("--device cuda: no CUDA device is available")
    return torch.device(name)


def _count(option: str, low: int, high: int):
    """An argparse type: a whole number in [low, high], else a one-line usage error naming the option."""

    def parse(text: str) -> int:
        word = text.strip()
        digits = word.removeprefix("-").removeprefix("+")
        if not (digits.isascii() and digits.isdigit()) or len(digits) > 30:
            raise argparse.ArgumentTypeError(f"{text[:20]!r} is not a whole number")
        value = int(word)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value:,} is out of range: {low:,} to {high:,}")
        return value

    return parse


def _output(path: str, dataset: str | None = None) -> Path:
    """The output folder: allowed ($SIMGEN_OUTPUT_ROOTS), it or the nearest folder that exists above it a folder,
    and not inside `dataset`, the dataset the command reads."""
    check_output_allowed(path)
    out = Path(path)
    existing = next((p for p in (out, *out.absolute().parents) if p.exists()), Path("/"))
    if not existing.is_dir():
        raise UserError(f"-o {path}: {existing} exists and is not a folder")
    if dataset is not None:
        read, target = Path(dataset).resolve(), out.resolve()
        if target == read or read in target.parents:
            raise UserError(f"-o {path}: inside the dataset it reads ({dataset}); write elsewhere")
    return out


def _dataset(path: str) -> simgen.datasets.Dataset:
    return simgen.datasets.open(path)  # a missing or foreign folder fails here, in one line


def _split(name: str) -> str | None:
    return None if name == "all" else name


def _model(
    checkpoint_path: str, dataset: simgen.datasets.Dataset | None, device: torch.device
) -> tuple[Detector, DetectorConfig, int]:
    """The checkpoint's detector, once its inference (one window at a time, train.detector.streaming) is known
    to fit the device (when the dataset tells its points per frame)."""
    checkpoint = load_checkpoint(checkpoint_path)
    config = checkpoint.config
    if dataset is not None:
        check_memory(config, dataset_points_per_frame(dataset), device, training=False, batch=1)
    model = Detector(config)
    try:
        model.load_state_dict(checkpoint.model)
    except RuntimeError:
        raise UserError(f"{checkpoint_path}: its weights do not fit its config") from None
    return model, config, checkpoint.iteration


def _overridden(config: DetectorConfig, source: str, **train: int | None) -> DetectorConfig:
    """The config with the command's options for `train` fields, validated again."""
    changes = {k: v for k, v in train.items() if v is not None}
    if not changes:
        return config
    data = config.model_dump(mode="json")
    data["train"].update(changes)
    return parse_config(data, f"{source} (with {', '.join(f'--{k} {v}' for k, v in changes.items())})")


def _preflight(config: DetectorConfig, points_per_frame: int, device: torch.device) -> None:
    """Refuse a training the machine cannot run: loader processes beyond its cores, memory beyond the device's."""
    check_workers(config)
    check_memory(config, points_per_frame, device, training=True)


def _fit(args: argparse.Namespace) -> int:
    config = _overridden(load_config(args.config), args.config, iterations=args.iterations, workers=args.workers)
    out, dataset, device = _output(args.output, args.dataset), _dataset(args.dataset), _device(args.device)
    _preflight(config, dataset_points_per_frame(dataset), device)
    result = fit(config, args.dataset, out, device, not args.quiet, resume=args.resume, overwrite=args.overwrite,
                 stop_at=args.stop_at, stop_after_s=args.stop_after)
    print(f"{result.checkpoint}: {result.iterations} iterations, {result.samples_per_s:.2f} samples/s")
    if result.stopped:
        print(f"stopped at iteration {result.iterations} of {config.train.iterations}: run the same command with "
              "--resume to continue")
    return 0


def _write_scores(out: Path, result: EvalResult, extra: dict[str, str]) -> None:
    """ap.csv and, with a distance bin, ap_by_distance.csv, by zone ap_by_zone.csv; the tables printed."""
    out.mkdir(parents=True, exist_ok=True)
    write_ap_csv(out / "ap.csv", result.rows, extra)
    print(format_ap_table(result.rows))
    if result.distance is not None:
        write_distance_csv(out / "ap_by_distance.csv", result.distance, extra)
        print(format_distance_table(result.distance))
        print(f"{out / 'ap_by_distance.csv'}")
    if result.zone is not None:
        write_zone_csv(out / "ap_by_zone.csv", result.zone, extra)
        print(format_zone_table(result.zone))
        print(f"{out / 'ap_by_zone.csv'}")


def _eval(args: argparse.Namespace) -> int:
    out, dataset, device = _output(args.output, args.dataset), _dataset(args.dataset), _device(args.device)
    model, config, iteration = _model(args.checkpoint, dataset, device)
    result = evaluate(model, config, args.dataset, _split(args.split), device, not args.quiet, args.by_distance,
                      args.by_zone)
    _write_scores(out, result, {"model": config.name, "iteration": str(iteration), "split": args.split})
    print(f"{out / 'ap.csv'}: {config.name} at iteration {iteration}, {result.frames_per_s:.2f} frames/s")
    return 0


def _score(args: argparse.Namespace) -> int:
    out, config = _output(args.output, args.dataset), load_config(args.config)
    _dataset(args.dataset)
    start = time.perf_counter()
    results = tracklet_results([Path(p) for p in args.tracklets], Path(args.dataset), config)
    result = score(results, args.dataset, args.by_distance, start, args.by_zone)
    clips = sorted({s.clip for s, _ in results})
    _write_scores(out, result, {"model": config.name, "clips": " ".join(clips)})
    print(f"{out / 'ap.csv'}: {config.name}'s tracklets of {len(clips)} clip{'' if len(clips) == 1 else 's'}, "
          f"{len(results)} frames")
    return 0


def _detect(args: argparse.Namespace) -> int:
    out, dataset, device = _output(args.output, args.dataset), _dataset(args.dataset), _device(args.device)
    model, config, _ = _model(args.checkpoint, dataset, device)
    paths = detect(model, config, args.dataset, _split(args.split), device, out, not args.quiet)
    print(f"{out}: tracklets of {len(paths)} clips in tracklets/, KITTI labels in kitti/")
    return 0


def _track(args: argparse.Namespace) -> int:
    sources = [name for name in ("checkpoint", "tracklets", "detections") if getattr(args, name) is not None]
    if len(sources) != 1:
        raise UserError("give exactly one source of detections: --checkpoint, --tracklets or --detections"
                        + (f" (got {' and '.join('--' + s for s in sources)})" if sources else ""))
    if (args.dataset is None) == (args.bag is None):
        raise UserError("give --dataset or --bag, not both" if args.dataset else "give --dataset or --bag")
    if args.bag is not None and args.checkpoint is None:
        raise UserError("--bag holds points only: it needs --checkpoint to detect players")
    if args.rate is not None and not args.online:
        raise UserError("--rate paces frames as a sensor delivers them: it needs --online")
    if args.resume and (args.online or args.bag is not None or args.rerun is not None):
        raise UserError("--resume goes on with an offline run over a dataset: not with --online, --bag or --rerun")
    if args.rerun is not None:
        if args.rerun.suffix != ".rrd" or args.rerun.is_dir():
            raise UserError(f"--rerun {args.rerun}: expected a file name ending in .rrd")
        check_output(args.rerun, "file", reads=[p for p in (args.dataset, args.bag) if p is not None])
    tracker = load_tracker_config(args.tracker)
    out, device = _output(args.output), _device(args.device)
    dataset = _dataset(args.dataset) if args.dataset is not None else None
    model = None
    if args.checkpoint is not None:
        detector, config, _ = _model(args.checkpoint, dataset, device)
        model = Model(detector, config)
    rule = TrackletFilter(args.min_score, "centre", args.nms_m) if args.min_score or args.nms_m else None
    options = TrackOptions(
        out, tracker, args.dataset, None if args.bag is None else Path(args.bag), args.ros2_layout, model,
        None if args.tracklets is None else Path(args.tracklets),
        None if args.detections is None else Path(args.detections),
        _split(args.split), args.online, args.rate, args.queue, rule, device, not args.quiet, resume=args.resume,
        rerun=args.rerun,
    )
    command = shlex.join(["simgen-train", *sys.argv[1:]]) if sys.argv[1:2] == ["track"] else "simgen-train track"
    result = run_track(options, lambda folder, r: write_metrics(folder, r, tracker.name, command))
    clips = f"{len(result.clips)} clip{'' if len(result.clips) == 1 else 's'}"
    print(f"{out}: {result.tracks} tracks over {result.frames} frames of {clips} in "
          f"{result.seconds:.1f} s; kitti/<clip>.txt, tracks.parquet, mcap/<clip>.mcap")
    if result.latency is not None:
        print(result.latency.summary())
        paced = f" at {args.rate:g} Hz" if args.rate is not None else ""
        print(f"online{paced}: {result.late} late, {result.dropped} dropped of {result.frames + result.dropped} "
              f"frames; latency.csv")
    if result.metrics is not None:
        print(f"{tracker.name}: {metrics_text(result, tracker.name)} (metrics.md, metrics.csv)")
    else:
        print("no labels with track ids: no metrics")
    return 0


def _study_options(args: argparse.Namespace, scenario_path: str, models_text: str, configs: str,
                   out: str) -> tuple[StudyOptions, Scenario]:
    """One scenario's study, checked before it starts: its scenario, models, detector and tracker configs, and
    that each model's training fits this machine (points per frame from the scenario's sensors)."""
    scenario = load_scenario(scenario_path)
    models = parse_models(models_text, scenario.scan.density)
    if args.seeds is not None and args.seed is not None:
        raise UserError("study: give --seed or --seeds, not both")
    options = StudyOptions(
        Path(scenario_path),
        _output(out),
        Path(args.datasets),
        models,
        args.iterations,
        args.workers,
        args.seed,
        Path(configs),
        _device(args.device),
        not args.quiet,
        Path(args.trackers),
        args.split,
    )
    load_tracker_configs(options.trackers)
    for model in models:
        _preflight(model_config(options, model), scenario_points_per_frame(scenario), options.device)
    return options, scenario


def _one_study(args: argparse.Namespace, options: StudyOptions, scenario: Scenario) -> list[Path]:
    """One scenario's study (once per seed with --seeds); returns the table files."""
    spelled = [
        str(options.scenario),
        "-o",
        str(options.out),
        "--models",
        ",".join(options.models),
        "--datasets",
        args.datasets,
    ]
    spelled += ["--device", args.device]
    for key in ("iterations", "workers", "seed", "split"):
        spelled += [f"--{key}", str(getattr(args, key))] if getattr(args, key) is not None else []
    spelled += ["--seeds", ",".join(map(str, args.seeds))] if args.seeds is not None else []
    spelled += ["--configs", str(options.configs)] if options.configs != CONFIGS else []
    spelled += ["--trackers", str(options.trackers)] if options.trackers != TRACKER_CONFIGS else []
    command = shlex.join(["simgen-train", "study", *spelled])
    if args.seeds is None:
        return write_tables(run_study(options, scenario), command, options.out)
    paths, results = [], []
    for run in tqdm(seed_runs(options, args.seeds), desc="study --seeds", unit="seed", disable=args.quiet):
        results.append(run_study(run, scenario))
        paths += write_tables(results[-1], command, run.out)
    return paths + write_seed_tables(results, args.seeds, command, options.out)


def _study(args: argparse.Namespace) -> int:
    if (args.scenario is None) == (args.preset is None):
        raise UserError("study: give a scenario YAML or --preset, not both")
    if args.scenario is not None:
        studies = [_study_options(args, args.scenario, args.models, args.configs, args.output)]
    else:
        configs, runs = PRESETS[args.preset]
        studies = [_study_options(args, str(SCENARIOS / scenario), ",".join(models), str(configs),
                                  str(Path(args.output) / Path(scenario).stem)) for scenario, models in runs]
    paths = []
    for options, scenario in tqdm(studies, desc="study", unit="scenario", disable=args.quiet or len(studies) == 1):
        paths += _one_study(args, options, scenario)
    print("\n".join(str(p) for p in paths))
    return 0


def _table2(args: argparse.Namespace) -> int:
    """Table 2 of tracklet files: each tracker's filter read from --filters-from, or chosen on --choose-on (else on
    the tracked files), then every tracker on the tracked files, scored against the dataset's labels, and what its
    birth/death and split modules did."""
    if args.filters_from is not None and args.choose_on is not None:
        raise UserError("give --filters-from or --choose-on, not both")
    out, config = _output(args.output), load_config(args.config)
    configs = load_tracker_configs(args.trackers)
    dataset = Path(args.dataset)
    start = time.perf_counter()
    tracked = tracklet_clip_set([Path(p) for p in args.tracklets], dataset, config)
    if args.filters_from is not None:
        filters = given_filters(tracked, configs, read_filters(Path(args.filters_from)), args.filters_from)
        chosen_on = f"as `{args.filters_from}` names it (a study's choice on its own train clips; not chosen here)"
    else:
        choose_on = tracked if args.choose_on is None else tracklet_clip_set([Path(p) for p in args.choose_on],
                                                                              dataset, config)
        frames = sum(len(choose_on.frames[c]) for c in choose_on.clips)
        where = ("the tracked clips themselves (no other tracklets given: an optimistic choice)"
                 if args.choose_on is None else f"clips {', '.join(choose_on.clips)}, not the tracked ones")
        chosen_on = (f"chosen on {where} ({frames} frames): of the grid at the end, the filter under which that "
                     "tracker reaches its highest sAMOTA (IoU 0.25) there")
        filters = choose_tracklet_filters(choose_on, tracked, configs, not args.quiet, args.workers)
    results, zoned = track(tracked, configs, filters, not args.quiet, args.by_zone)
    by_zone = zoned if args.by_zone else None
    counts, pairs = module_counts(tracked, configs, filters), split_window_pairs(tracked, configs, filters)
    command = shlex.join(["simgen-train", "table2", *args.tracklets, "--dataset", args.dataset, "--config",
                          args.config, "-o", args.output, "--workers", str(args.workers)]
                         + (["--choose-on", *args.choose_on] if args.choose_on else [])
                         + (["--filters-from", args.filters_from] if args.filters_from else [])
                         + (["--trackers", args.trackers] if Path(args.trackers) != TRACKER_CONFIGS else [])
                         + (["--by-zone"] if args.by_zone else []))
    texts = {"table2.md": tracking_markdown(command, tracked, results, filters, chosen_on, counts, pairs,
                                            time.perf_counter() - start, by_zone),
             "table2.csv": tracking_csv(results, filters),
             **({"table2_by_zone.csv": zone_csv(by_zone, filters)} if by_zone is not None else {})}
    out.mkdir(parents=True, exist_ok=True)
    for name, text in texts.items():
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
        print(out / name)
    return 0


def _seed_list(text: str) -> tuple[int, ...]:
    try:
        return parse_seeds(text)
    except UserError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("--seeds: ")) from None


def _bounded(what: str, low: float, high: float, unit: str = "", above_low: bool = False):
    """An argparse type: a number (`what`, in `unit`) from low (or above it, `above_low`) to high."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text[:20]!r} is not {what}") from None
        if not (low < value if above_low else low <= value) or not value <= high:
            start = f"more than {low:g}" if above_low else f"{low:g}"
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: {start} to {high:g}{unit}")
        return value

    return parse


def _seconds(text: str) -> float:
    """An argparse type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text[:20]!r} is not a number of seconds") from None
    if not 0 < value < 1e9:
        raise argparse.ArgumentTypeError(f"{value:g} is out of range: more than 0 and under 1e9 seconds")
    return value


ITERATIONS = _count("--iterations", 1, MAX_ITERATIONS)
WORKERS = _count("--workers", 0, MAX_WORKERS)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="simgen-train",
        description="Train and evaluate the paper's PointPillars tracklet detector on datasets written by "
        "`simgen generate`, read through simgen.datasets.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("--dataset", required=True, help="a dataset folder written by `simgen generate`")
        p.add_argument("-o", "--output", required=True, help="output folder (created)")
        p.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto", help="default: CUDA when present")
        p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("fit", help="train a detector on the dataset's train clips")
    p.add_argument("config", help="detector config YAML (train/configs/single|early|late.yaml)")
    common(p)
    p.add_argument("--iterations", type=ITERATIONS, help="override train.iterations")
    p.add_argument("--workers", type=WORKERS, help="override train.workers (loader processes, at most the CPU cores)")
    p.add_argument("--resume", action="store_true", help="continue the fit in OUTPUT from its checkpoint (weights, "
                   "optimiser, schedule and sample stream) and its log: the same weights as one uninterrupted fit")
    p.add_argument("--overwrite", action="store_true", help="replace the run OUTPUT holds (without --resume or this, "
                   "a folder holding a checkpoint or a log is refused)")
    p.add_argument("--stop-at", type=ITERATIONS, metavar="ITERATION", help="checkpoint at this iteration and stop "
                   "(then --resume)")
    p.add_argument("--stop-after", type=_seconds, metavar="SECONDS", help="checkpoint once this run has trained this "
                   "long and stop (then --resume): a long fit as several commands under a time limit")
    p.set_defaults(func=_fit)

    def tracklet_inputs(p: argparse.ArgumentParser, output: str) -> None:
        p.add_argument("tracklets", nargs="+", help="tracklet .npz files, one per clip")
        p.add_argument("--dataset", required=True, help="the dataset the tracklets were detected on (its labels)")
        p.add_argument("--config", required=True, help="the detector config that made them: its classes and point "
                       "range select the labelled boxes, as in the study")
        p.add_argument("-o", "--output", required=True, help=output)

    def by_distance(p: argparse.ArgumentParser) -> None:
        p.add_argument("--by-distance", nargs="?", const=DISTANCE_BIN_M, metavar="M",
                       type=_bounded("a number of metres", 0.0, 1000.0, " m", above_low=True),
                       help="also AP by distance from the dataset's sensor into ap_by_distance.csv: the boxes at t "
                       f"in bins of M metres (default {DISTANCE_BIN_M:g}) of their centre's pitch-plane distance "
                       "from the nearest sensor; in each bin, labelled boxes outside it are ignored and a detection "
                       "that matches no counted box is a false positive only if its own centre is in the bin")
        p.add_argument("--by-zone", action="store_true", help="also AP by pitch zone into ap_by_zone.csv: the boxes "
                       "at t whose centre is in the paper's detection box ([-40, 40] m in x and y) and outside it, "
                       "each zone scored as a --by-distance bin")

    for name, func, text in (("eval", _eval, "detection AP (BEV, 3D; IoU 0.5; R40 and R11) into ap.csv"),
                             ("detect", _detect, "tracklet files and KITTI labels per frame")):
        p = sub.add_parser(name, help=text)
        p.add_argument("checkpoint", help="checkpoint.pt written by `simgen-train fit`")
        common(p)
        p.add_argument("--split", choices=SPLITS, default="val", help="clips to run on (default: val)")
        if name == "eval":
            by_distance(p)
        p.set_defaults(func=func)

    p = sub.add_parser("score", help="detection AP of tracklet files already written (`detect`), as eval's, into "
                       "ap.csv", description="Score tracklet files of `simgen-train detect` (or a study's) against "
                       "the dataset's labels as `simgen-train eval` scores a checkpoint: every frame t with two "
                       "before it, the labelled boxes of the config's classes whose centre at t is in its point "
                       "range; AP at t, t-1 and t-2 on all boxes and on the visible ones.")
    tracklet_inputs(p, "output folder (created): ap.csv, with --by-distance ap_by_distance.csv, with --by-zone "
                    "ap_by_zone.csv")
    by_distance(p)
    p.set_defaults(func=_score)

    p = sub.add_parser("track", help="track players: detections from a checkpoint, tracklet files or KITTI files "
                       "-> the paper's tracker -> KITTI tracking results, a tracks table, MCAP bags and metrics",
                       description="Track the players of a dataset's clips (or of a ROS 2 MCAP bag of points) with "
                       "the paper's 3D DIoU tracker or any tracker YAML. Detections come from exactly one source: "
                       "--checkpoint (our detector), --tracklets (files of `simgen-train detect`) or --detections "
                       "(KITTI object files with a 16th column, the score: DIR/<clip>/<frame:06d>.txt, boxes in the "
                       "dataset's KITTI camera; single-frame boxes are associated frame to frame). OUT gets "
                       "kitti/<clip>.txt (KITTI tracking results), tracks.parquet (clip, frame, time, track id, box, "
                       "score, state), mcap/<clip>.mcap (points, labels and tracks as markers with trajectories, "
                       "for Foxglove or RViz) and, where the clips have labels, metrics.md and metrics.csv (sAMOTA, "
                       "AMOTA, AMOTP, MOTA, MOTP, IDS, FRAG, HOTA). --online runs frame by frame as a sensor "
                       "delivers them, with latency.csv. OUT's files are replaced only when the run succeeds.")
    p.add_argument("--dataset", help="a dataset folder written by `simgen generate` (or give --bag)")
    p.add_argument("--bag", metavar="BAG", help="instead of a dataset: a ROS 2 bag of points, its folder or its MCAP "
                   "(needs "
                   "--checkpoint; its /simgen/boxes, if any, are the labels)")
    p.add_argument("--ros2-layout", choices=("simgen", "livox"), default="simgen", help="the bag's PointCloud2 "
                   "points: simgen (pitch frame, default) or livox (livox_ros_driver2's, each sensor's frame, posed "
                   "by /tf_static)")
    p.add_argument("-o", "--output", required=True, help="output folder (created)")
    p.add_argument("--checkpoint", help="checkpoint.pt of `simgen-train fit`: detect, then track")
    p.add_argument("--tracklets", metavar="DIR", help="tracklet files DIR/<clip>.npz of `simgen-train detect`")
    p.add_argument("--detections", metavar="DIR", help="KITTI object files with a score, DIR/<clip>/<frame:06d>.txt")
    p.add_argument("--tracker", default=str(TRACKER_CONFIGS / DEFAULT_TRACKER), metavar="YAML",
                   help=f"tracker config (default: the paper's full tracker, train/configs/tracking/{DEFAULT_TRACKER})")
    p.add_argument("--split", choices=SPLITS, default="val", help="clips to track (default: val)")
    p.add_argument("--min-score", type=_bounded("a score", 0.0, 1.0), default=DEFAULT_FILTER.min_score, metavar="S",
                   help=f"track only detections scoring at least S (default {DEFAULT_FILTER.min_score:g})")
    p.add_argument("--nms-m", type=_bounded("a number of metres", 0.0, 10.0, " m"),
                   default=DEFAULT_FILTER.nms_threshold, metavar="M",
                   help="drop a detection whose centre is within M metres of a better one (default "
                   f"{DEFAULT_FILTER.nms_threshold:g}; 0: none)")
    p.add_argument("--online", action="store_true", help="frame by frame, as a sensor delivers them, nothing looking "
                   "ahead; each stage's latency per frame in latency.csv")
    p.add_argument("--rate", type=_bounded("a number of frames per second", 0.0, 1000.0, " Hz", above_low=True),
                   metavar="HZ", help="with --online: frames arrive at HZ; count late "
                   "and dropped frames")
    p.add_argument("--queue", type=_count("--queue", 1, 10_000), default=DEFAULT_QUEUE, metavar="N",
                   help=f"with --rate: a frame is dropped when N newer ones wait (default {DEFAULT_QUEUE})")
    p.add_argument("--rerun", type=Path, metavar="FILE.rrd", help="also a Rerun recording of the points, labels and "
                   "tracks (one colour per id, trajectories), each clip under world/<clip>; open it with `rerun "
                   "FILE.rrd`")
    p.add_argument("--resume", action="store_true", help="go on with a run into OUT that was killed, from its last "
                   "completed chunk of 100 frames, with the same options (offline, from a dataset); the outputs are "
                   "those of an uninterrupted run, byte for byte. Without a killed run there, start afresh")
    p.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto", help="default: CUDA when present")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_track)

    p = sub.add_parser("study", help="a scenario -> its dataset -> the paper's Table 1 (AP) and Table 2 (tracking) "
                       "in OUT")
    p.add_argument("scenario", nargs="?", help="scenario YAML (scenarios/); its dataset is DATASETS/<name>, made if "
                   "missing")
    p.add_argument("--preset", choices=sorted(PRESETS), help="instead of a scenario: `paper` runs the paper's Table 1 "
                   "(x1: single, early, late; x2: single, late) and Table 2 with the paper-size configs "
                   "(train/configs/paper/, for a GPU: docs/gpu_study.md) into OUT/paper_x1/ and OUT/paper_x2/")
    p.add_argument("-o", "--output", required=True, help="output folder (created): table1/2.md and .csv, a run per "
                   "model")
    p.add_argument("--models", default="late", help="Table 1 rows, comma-separated: late and any of single, early "
                   "(default: late; --preset sets them)")
    p.add_argument("--iterations", type=ITERATIONS, help="training batches per model (default: each config's)")
    p.add_argument("--workers", type=WORKERS, help="override train.workers (loader processes, at most the CPU cores)")
    p.add_argument("--seed", type=_count("--seed", 0, MAX_SEED), help="override the configs' seed")
    p.add_argument("--seeds", type=_seed_list, help="train and score every model once per seed, e.g. 0,1,2: "
                   "OUT/seed_<seed>/ each, and OUT/table1.md, table2.md with mean, spread and whether the paper's "
                   "orderings hold beyond it")
    p.add_argument("--split", choices=("clip", "frame"), help="train/val split for every model (default: the "
                   "configs', clip): clip holds out whole clips; frame holds out every k-th t-2..t window of every "
                   "clip, no training window sharing a frame with a val one (Table 2 needs clip)")
    p.add_argument("--datasets", default="datasets", help="folder of datasets by scenario name (default: datasets)")
    p.add_argument("--configs", default=str(CONFIGS), help="folder with single/early/late.yaml (default: "
                   "train/configs; --preset sets it)")
    p.add_argument("--trackers", default=str(TRACKER_CONFIGS), help="folder of tracker configs, one per Table 2 row "
                   "(default: train/configs/tracking)")
    p.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto", help="default: CUDA when present")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_study)

    p = sub.add_parser("table2", help="Table 2 of tracklet files already written (`detect`, a study's "
                       "late/tracklets/): every tracker on them, scored against the dataset's labels, into OUT")
    tracklet_inputs(p, "output folder (created): table2.md and table2.csv")
    p.add_argument("--choose-on", nargs="+", metavar="TRACKLETS", help="tracklet files of other clips (e.g. the "
                   "train clips') on which each tracker's filter is chosen, as the study does; default: the tracked "
                   "files themselves, an optimistic choice that the table states")
    p.add_argument("--filters-from", metavar="TABLE2_CSV", help="instead of choosing: each tracker's filter as a "
                   "study's table2.csv names it (e.g. a CPU study's, chosen on its own train clips)")
    p.add_argument("--trackers", default=str(TRACKER_CONFIGS), help="folder of tracker configs, one per Table 2 row "
                   "(default: train/configs/tracking)")
    p.add_argument("--workers", type=WORKERS, default=1, help="processes scoring the candidate filters (default 1)")
    p.add_argument("--by-zone", action="store_true", help="also Table 2 in each pitch zone (the paper's detection "
                   "box, [-40, 40] m in x and y, and outside it): tracks and labels cut to the zone frame by frame; "
                   "into table2.md and table2_by_zone.csv")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_table2)
    return parser


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr, as errors are (e.g. an old config's `fusion: none`)."""
    print(f"simgen-train: warning: {' '.join(str(message).splitlines())}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with warnings.catch_warnings():
        warnings.showwarning = _warning_line
        return dispatch("simgen-train", args)


if __name__ == "__main__":
    sys.exit(main())
