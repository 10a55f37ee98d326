"""`simgen-train fit | eval | detect | study`: the paper's PointPillars tracklet detector on simgen datasets.

Datasets are read only through simgen.datasets. Bad input (a missing dataset or config, a file
that is not our checkpoint) is one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import torch
from tqdm import tqdm

import simgen.datasets
from simgen.cli import dispatch
from simgen.errors import UserError
from simgen.scenario import load_scenario
from train.checkpoint import load_checkpoint
from train.config import DetectorConfig, load_config
from train.evaluate import detect, evaluate, format_ap_table, write_ap_csv
from train.fit import fit
from train.models.detector import Detector
from train.study import CONFIGS, PRESETS, SCENARIOS, StudyOptions, parse_models, run_study, seed_runs
from train.study_report import write_tables
from train.study_seeds import write_seed_tables

SPLITS = ("train", "val", "all")


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors are one line (argparse already exits 2)."""

    def error(self, message: str) -> None:  # noqa: D102 - argparse API
        self.exit(2, f"{self.prog}: error: {message}\n")


def _device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise UserError("--device cuda: no CUDA device is available")
    return torch.device(name)


def _dataset(path: str) -> str:
    simgen.datasets.open(path)  # a missing or foreign folder fails here, in one line
    return path


def _split(name: str) -> str | None:
    return None if name == "all" else name


def _model(checkpoint_path: str) -> tuple[Detector, DetectorConfig, int]:
    checkpoint = load_checkpoint(checkpoint_path)
    model = Detector(checkpoint.config)
    try:
        model.load_state_dict(checkpoint.model)
    except RuntimeError:
        raise UserError(f"{checkpoint_path}: its weights do not fit its config") from None
    return model, checkpoint.config, checkpoint.iteration


def _fit(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    changes = {k: v for k, v in (("iterations", args.iterations), ("workers", args.workers)) if v is not None}
    if changes:
        config = config.model_copy(update={"train": config.train.model_copy(update=changes)})
    result = fit(config, _dataset(args.dataset), Path(args.output), _device(args.device), not args.quiet,
                 resume=args.resume, stop_at=args.stop_at, stop_after_s=args.stop_after)
    print(f"{result.checkpoint}: {result.iterations} iterations, {result.samples_per_s:.2f} samples/s")
    if result.stopped:
        print(f"stopped at iteration {result.iterations} of {config.train.iterations}: run the same command with "
              "--resume to continue")
    return 0


def _eval(args: argparse.Namespace) -> int:
    model, config, iteration = _model(args.checkpoint)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    result = evaluate(model, config, _dataset(args.dataset), _split(args.split), _device(args.device), not args.quiet)
    write_ap_csv(out / "ap.csv", result.rows, {"model": config.name, "iteration": str(iteration), "split": args.split})
    print(format_ap_table(result.rows))
    print(f"{out / 'ap.csv'}: {config.name} at iteration {iteration}, {result.frames_per_s:.2f} frames/s")
    return 0


def _detect(args: argparse.Namespace) -> int:
    model, config, _ = _model(args.checkpoint)
    paths = detect(model, config, _dataset(args.dataset), _split(args.split), _device(args.device), Path(args.output), not args.quiet)
    print(f"{Path(args.output)}: tracklets of {len(paths)} clips in tracklets/, KITTI labels in kitti/")
    return 0


def _seeds(text: str | None) -> tuple[int, ...] | None:
    """`--seeds 0,1,2` -> (0, 1, 2): distinct non-negative integers."""
    if text is None:
        return None
    try:
        seeds = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise UserError(f"--seeds: {text!r} is not a comma-separated list of integers") from None
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise UserError(f"--seeds: {text!r}: give distinct seeds >= 0")
    return seeds


def _one_study(args: argparse.Namespace, scenario_path: str, models_text: str, configs: str, out: str) -> list[Path]:
    """One scenario's study (once per seed with --seeds); returns the table files."""
    scenario = load_scenario(scenario_path)
    models = parse_models(models_text, scenario.scan.density)
    seeds = _seeds(args.seeds)
    if seeds is not None and args.seed is not None:
        raise UserError("study: give --seed or --seeds, not both")
    options = StudyOptions(Path(scenario_path), Path(out), Path(args.datasets), models, args.iterations, args.workers,
                           args.seed, Path(configs), _device(args.device), not args.quiet, split=args.split)
    spelled = [scenario_path, "-o", out, "--models", ",".join(models), "--datasets", args.datasets]
    spelled += ["--device", args.device]
    for key in ("iterations", "workers", "seed", "seeds", "split"):
        spelled += [f"--{key}", str(getattr(args, key))] if getattr(args, key) is not None else []
    spelled += ["--configs", configs] if Path(configs) != CONFIGS else []
    command = shlex.join(["simgen-train", "study", *spelled])
    if seeds is None:
        return write_tables(run_study(options, scenario), command, options.out)
    paths, results = [], []
    for run in tqdm(seed_runs(options, seeds), desc="study --seeds", unit="seed", disable=args.quiet):
        results.append(run_study(run, scenario))
        paths += write_tables(results[-1], command, run.out)
    return paths + write_seed_tables(results, seeds, command, options.out)


def _study(args: argparse.Namespace) -> int:
    if args.iterations is not None and args.iterations < 1:
        raise UserError(f"--iterations: {args.iterations} is not a positive number of batches")
    if (args.scenario is None) == (args.preset is None):
        raise UserError("study: give a scenario YAML or --preset, not both")
    if args.scenario is not None:
        paths = _one_study(args, args.scenario, args.models, args.configs, args.output)
    else:
        configs, runs = PRESETS[args.preset]
        paths = []
        for scenario, models in tqdm(runs, desc=f"study --preset {args.preset}", unit="scenario", disable=args.quiet):
            out = str(Path(args.output) / Path(scenario).stem)
            paths += _one_study(args, str(SCENARIOS / scenario), ",".join(models), str(configs), out)
    print("\n".join(str(p) for p in paths))
    return 0


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
    p.add_argument("--iterations", type=int, help="override train.iterations")
    p.add_argument("--workers", type=int, help="override train.workers (loader processes)")
    p.add_argument("--resume", action="store_true", help="continue the fit in OUTPUT from its checkpoint (weights, "
                   "optimiser, schedule and sample stream): the same weights as one uninterrupted fit")
    p.add_argument("--stop-at", type=int, metavar="ITERATION", help="checkpoint at this iteration and stop (then --resume)")
    p.add_argument("--stop-after", type=float, metavar="SECONDS", help="checkpoint once this run has trained this long "
                   "and stop (then --resume): a long fit as several commands under a time limit")
    p.set_defaults(func=_fit)

    for name, func, text in (("eval", _eval, "detection AP (BEV, 3D; IoU 0.5; R40 and R11) into ap.csv"),
                             ("detect", _detect, "tracklet files and KITTI labels per frame")):
        p = sub.add_parser(name, help=text)
        p.add_argument("checkpoint", help="checkpoint.pt written by `simgen-train fit`")
        common(p)
        p.add_argument("--split", choices=SPLITS, default="val", help="clips to run on (default: val)")
        p.set_defaults(func=func)

    p = sub.add_parser("study", help="a scenario -> its dataset -> the paper's Table 1 (AP) and Table 2 (tracking) in OUT")
    p.add_argument("scenario", nargs="?", help="scenario YAML (scenarios/); its dataset is DATASETS/<name>, made if missing")
    p.add_argument("--preset", choices=sorted(PRESETS), help="instead of a scenario: `paper` runs the paper's Table 1 (x1: "
                   "single, early, late; x2: single, late) and Table 2 with the paper-size configs (train/configs/paper/, "
                   "for a GPU: docs/gpu_study.md) into OUT/paper_x1/ and OUT/paper_x2/")
    p.add_argument("-o", "--output", required=True, help="output folder (created): table1/2.md and .csv, a run per model")
    p.add_argument("--models", default="late", help="Table 1 rows, comma-separated: late and any of single, early "
                   "(default: late; --preset sets them)")
    p.add_argument("--iterations", type=int, help="training batches per model (default: each config's)")
    p.add_argument("--workers", type=int, help="override train.workers (loader processes)")
    p.add_argument("--seed", type=int, help="override the configs' seed")
    p.add_argument("--seeds", help="train and score every model once per seed, e.g. 0,1,2: OUT/seed_<seed>/ each, and "
                   "OUT/table1.md, table2.md with mean, spread and whether the paper's orderings hold beyond it")
    p.add_argument("--split", choices=("clip", "frame"), help="train/val split for every model (default: the configs', "
                   "clip): clip holds out whole clips; frame holds out every k-th t-2..t window of every clip, no "
                   "training window sharing a frame with a val one (Table 2 needs clip)")
    p.add_argument("--datasets", default="datasets", help="folder of datasets by scenario name (default: datasets)")
    p.add_argument("--configs", default=str(CONFIGS), help="folder with single/early/late.yaml (default: train/configs; "
                   "--preset sets it)")
    p.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto", help="default: CUDA when present")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_study)
    return parser


def main(argv: list[str] | None = None) -> int:
    return dispatch("simgen-train", build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
