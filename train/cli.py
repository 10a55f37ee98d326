"""`simgen-train fit | eval | detect | study`: the paper's PointPillars tracklet detector on simgen datasets.

Datasets are read only through simgen.datasets. Bad input (a missing dataset or config, a file
that is not our checkpoint, an option out of range, a model that would not fit in the device's
memory, more loader processes than cores) is one line on stderr and exit code 2, found before
anything is trained or allocated (train.preflight).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import torch
from tqdm import tqdm

import simgen.datasets
from simgen.atomic import check_output_allowed
from simgen.cli import dispatch
from simgen.errors import UserError
from simgen.scenario import Scenario, load_scenario
from train.checkpoint import load_checkpoint
from train.config import MAX_ITERATIONS, MAX_SEED, MAX_WORKERS, DetectorConfig, load_config, parse_config
from train.detector.inference import detect
from train.detector.model import Detector
from train.evaluation.ap_table import evaluate, format_ap_table, write_ap_csv
from train.fit import fit
from train.preflight import (
    check_memory,
    check_workers,
    dataset_points_per_frame,
    parse_seeds,
    scenario_points_per_frame,
)
from train.study.report import write_tables
from train.study.run import (
    CONFIGS,
    PRESETS,
    SCENARIOS,
    TRACKER_CONFIGS,
    StudyOptions,
    model_config,
    parse_models,
    run_study,
    seed_runs,
)
from train.study.seeds import write_seed_tables
from train.tracking.config import load_tracker_configs

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
    checkpoint_path: str, dataset: simgen.datasets.Dataset, device: torch.device
) -> tuple[Detector, DetectorConfig, int]:
    """The checkpoint's detector, once its inference (one window at a time, train.detector.streaming) is known
    to fit the device."""
    checkpoint = load_checkpoint(checkpoint_path)
    config = checkpoint.config
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


def _eval(args: argparse.Namespace) -> int:
    out, dataset, device = _output(args.output, args.dataset), _dataset(args.dataset), _device(args.device)
    model, config, iteration = _model(args.checkpoint, dataset, device)
    result = evaluate(model, config, args.dataset, _split(args.split), device, not args.quiet)
    out.mkdir(parents=True, exist_ok=True)
    write_ap_csv(out / "ap.csv", result.rows, {"model": config.name, "iteration": str(iteration), "split": args.split})
    print(format_ap_table(result.rows))
    print(f"{out / 'ap.csv'}: {config.name} at iteration {iteration}, {result.frames_per_s:.2f} frames/s")
    return 0


def _detect(args: argparse.Namespace) -> int:
    out, dataset, device = _output(args.output, args.dataset), _dataset(args.dataset), _device(args.device)
    model, config, _ = _model(args.checkpoint, dataset, device)
    paths = detect(model, config, args.dataset, _split(args.split), device, out, not args.quiet)
    print(f"{out}: tracklets of {len(paths)} clips in tracklets/, KITTI labels in kitti/")
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


def _seed_list(text: str) -> tuple[int, ...]:
    try:
        return parse_seeds(text)
    except UserError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("--seeds: ")) from None


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

    for name, func, text in (("eval", _eval, "detection AP (BEV, 3D; IoU 0.5; R40 and R11) into ap.csv"),
                             ("detect", _detect, "tracklet files and KITTI labels per frame")):
        p = sub.add_parser(name, help=text)
        p.add_argument("checkpoint", help="checkpoint.pt written by `simgen-train fit`")
        common(p)
        p.add_argument("--split", choices=SPLITS, default="val", help="clips to run on (default: val)")
        p.set_defaults(func=func)

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
    return parser


def main(argv: list[str] | None = None) -> int:
    return dispatch("simgen-train", build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
