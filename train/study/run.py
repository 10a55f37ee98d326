"""`simgen-train study`: one scenario -> its dataset -> the paper's Table 1 (detection AP) and Table 2 (tracking).

1. The dataset: `DATASETS/<scenario name>` is reused when its manifest holds the same resolved
   scenario, else made by `simgen generate` in a subprocess (the public interface), which dies with
   the study (train.parent_death).
2. Table 1: each model asked for (`late` always) is trained on the `train` clips (train.fit), or
   reused from `OUT/<model>/` when that checkpoint has the same data and a config that gives the same
   weights (inference settings may differ: train.config.same_weights), else trained again there (the
   earlier run replaced), and its boxes at t
   are scored on the `val` clips (train.evaluation.ap_table: AP in BEV and 3D, IoU 0.5).
3. Table 2: the `late` model's tracklets are filtered for tracking (train.study.tracklet_filter: a score
   threshold and a tight NMS, chosen for each tracker by its own sAMOTA on the `train` clips, the filters
   scored in as many processes as the model's loader has), then
   the `val` clips' go to every tracker of train/configs/tracking/ (AB3DMOT with its own and with
   the player Kalman filter, the 3D DIoU tracker with and without birth/death and split), each
   through its own filter; their tracks are scored against the labels (train.evaluation), and so are
   the trackers' tracks of the unfiltered tracklets, for comparison.

Ground truth, as for AP: the objects of the detector's classes whose centre at t lies in its
point range, on every frame with two before it (the first frame a tracklet can describe).
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

import simgen.datasets
from simgen.atomic import atomic_path
from simgen.errors import UserError
from simgen.scenario import Scenario, parse_scenario
from train.checkpoint import load_checkpoint
from train.config import TRACKLET_FRAMES, DetectorConfig, load_config, parse_config, same_weights
from train.data import RecentFrames, Sample, crop, load_sample
from train.detector.detections import ClipTracklets, clip_tracklets, read_tracklets, write_tracklets
from train.detector.inference import predict
from train.detector.model import Detector
from train.detector.postprocess import Detections
from train.evaluation.ap_table import ApRow, average_precisions, visible_objects
from train.evaluation.decomposition import Decomposition, decompose
from train.evaluation.detection import FrameBoxes
from train.evaluation.hota import Hota, centre_hota, hota
from train.evaluation.tracker_modules import ClosePairs, ModuleCounts, close_pairs, count_modules
from train.evaluation.tracking import TrackingMetrics, evaluate_tracking
from train.evaluation.truth import TruthIds
from train.evaluation.zones import ZONES, tracks_in_zone, truth_in_zone
from train.fit import CHECKPOINT_NAME, fit
from train.parent_death import die_with_parent
from train.study.tracklet_filter import FilterScore, TrackletFilter, apply_filter, choose_filters
from train.tracking.clip import make_tracker, track_clip
from train.tracking.config import TrackerConfig, load_tracker_configs
from train.tracking.types import GroundTruthFrame, TrackedFrame, Tracklets

MODELS = ("single", "early", "late")  # the paper's Table 1 methods
TRACKED_MODEL = "late"
# The paper's Table 1 rows per point density (x1: single, early, late; x2: single, late).
PAPER_ROWS = {1.0: ("single", "early", "late"), 2.0: ("single", "late")}
MIN_IOUS = (0.25, 0.5)  # 3D IoU of a true positive: AB3DMOT's default, and the stricter one
CONFIGS = Path(__file__).parents[1] / "configs"
TRACKER_CONFIGS = CONFIGS / "tracking"  # one YAML per Table 2 row, in file-name order
SCENARIOS = Path(__file__).parents[2] / "scenarios"
# `--preset`: the paper's Tables 1 (all five rows) and 2 at its model size: (configs, (scenario, models) per study).
PRESETS = {"paper": (CONFIGS / "paper", (("paper_x1.yaml", PAPER_ROWS[1.0]), ("paper_x2.yaml", PAPER_ROWS[2.0])))}
TRAINED_ON = "trained_on.json"  # beside a study's checkpoint: the dataset and scenario it was fitted on
GENERATE_STATE = Path(".simgen") / "scenario.json"  # an interrupted `simgen generate` run


@dataclass(frozen=True)
class StudyOptions:
    scenario: Path  # scenario YAML
    out: Path
    datasets: Path  # folder of datasets, one per scenario name
    models: tuple[str, ...]
    iterations: int | None  # training batches per model; None: the configs'
    workers: int | None  # loader processes; None: the configs'
    seed: int | None  # None: the configs'
    configs: Path  # folder with <model>.yaml
    device: torch.device
    progress: bool
    trackers: Path = TRACKER_CONFIGS  # folder of tracker configs
    split: str | None = None  # `data.split` for every model (clip or frame); None: the configs'


@dataclass(frozen=True)
class StudyDataset:
    path: Path
    scenario: Scenario
    generated: bool  # False: reused
    seconds: float  # generating (or checking) it
    val_clips: tuple[str, ...]
    val_frames: int


@dataclass(frozen=True)
class DetectorResult:
    model: str
    config: DetectorConfig  # as trained (iterations, workers, seed applied)
    reused: bool  # checkpoint found in OUT/<model>/, not trained again
    fit_s: float
    eval_s: float
    rows: list[ApRow]  # AP of the boxes at t (and t-1, t-2 for late) on the val clips
    decomposition: Decomposition  # where the 3D AP of the boxes at t goes


@dataclass(frozen=True)
class TrackerResult:
    tracker: str
    filtered: bool  # False: the detector's tracklets as they are
    min_iou: float
    metrics: TrackingMetrics
    hota: Hota  # 3D IoU similarity
    centre_hota: Hota  # pitch-plane centre distance, 5 m Gaussian tolerance (as SoccerNet's GS-HOTA)


@dataclass(frozen=True)
class FilterChoice:
    """A tracker's tracklet filter and how it was chosen: every candidate's sAMOTA on the train clips."""

    chosen: TrackletFilter
    tracker: str
    scores: list[FilterScore]  # in train.study.tracklet_filter.GRID order
    train_frames: int  # frames of the clips it was chosen on
    val_tracklets_per_frame: tuple[float, float]  # before and after the filter


@dataclass(frozen=True)
class StudyResult:
    dataset: StudyDataset
    detectors: list[DetectorResult]
    trackers: list[TrackerResult]  # none with the frame split (no contiguous val sequence to track)
    filters: dict[str, FilterChoice]  # tracker name -> its filter; empty with the frame split
    tracking_s: float
    seconds: float  # the whole study
    device: str


def parse_models(text: str, density: float) -> tuple[str, ...]:
    """`late,single,...` -> models in Table 1 order; `late` is required, and at x1/x2 only the paper's rows."""
    asked = [m.strip() for m in text.split(",") if m.strip()]
    unknown = sorted(set(asked) - set(MODELS))
    if unknown:
        raise UserError(f"--models: unknown model {unknown[0]!r} (known: {', '.join(MODELS)})")
    if TRACKED_MODEL not in asked:
        raise UserError(f"--models: needs {TRACKED_MODEL!r}, whose tracklets Table 2 tracks")
    rows = PAPER_ROWS.get(density, MODELS)
    beyond = [m for m in asked if m not in rows]
    if beyond:
        raise UserError(f"--models: the paper's Table 1 has no {beyond[0]!r} row at density x{density:g} "
                        f"(it has {', '.join(rows)})")
    return tuple(m for m in MODELS if m in asked)


def prepare_dataset(scenario_path: Path, scenario: Scenario, datasets: Path, progress: bool) -> StudyDataset:
    """Reuse `datasets/<name>` if it holds this resolved scenario; else `simgen generate` it (resuming a broken run)."""
    root = datasets / scenario.name
    start = time.perf_counter()
    generated = not (root / "manifest.json").is_file()
    if generated:
        command = [sys.executable, "-m", "simgen.cli", "generate", str(scenario_path), "-o", str(root)]
        command += ["--resume"] if (root / GENERATE_STATE).is_file() else []
        quiet = None if progress else subprocess.PIPE
        done = subprocess.run(command, stdout=quiet, stderr=quiet, text=True,
                              preexec_fn=functools.partial(die_with_parent, os.getpid()))
        if done.returncode:
            said = (done.stderr or "").strip().splitlines()[-1:]
            raise UserError(
                f"simgen {' '.join(command[4:])}: exit {done.returncode}" + (f" ({said[0]})" if said else "")
            )
    dataset = simgen.datasets.open(root)
    found = parse_scenario(dataset.manifest.scenario, f"{root}/manifest.json").model_dump(mode="json")
    if found != scenario.model_dump(mode="json"):
        raise UserError(
            f"{root}: holds a dataset of another scenario named {scenario.name!r}; move it or pass --datasets"
        )
    val = tuple(c for c in dataset.clips if dataset.split(c) == "val")
    if not val:
        raise UserError(f"{root}: no clips in the 'val' split (a dataset needs 2 clips or more)")
    frames = sum(dataset.num_frames(c) for c in val)
    return StudyDataset(root, scenario, generated, time.perf_counter() - start, val, frames)


def seed_runs(options: StudyOptions, seeds: tuple[int, ...]) -> list[StudyOptions]:
    """The study once per training seed, each into OUT/seed_<seed>/ (the data stays the same)."""
    return [replace(options, seed=seed, out=options.out / f"seed_{seed}") for seed in seeds]


def model_config(options: StudyOptions, model: str) -> DetectorConfig:
    """`<configs>/<model>.yaml` with the study's iterations, workers and seed, validated again."""
    path = options.configs / f"{model}.yaml"
    data = load_config(path).model_dump(mode="json")
    data["train"].update(
        {k: v for k, v in (("iterations", options.iterations), ("workers", options.workers)) if v is not None}
    )
    if options.seed is not None:
        data["seed"] = options.seed
    if options.split is not None:
        data["data"]["split"] = options.split
    config = parse_config(data, f"{path} (with the study's options)")
    if config.model.method != model:
        raise UserError(f"{path}: is a {config.model.method!r} model, the study needs {model!r} there")
    return config


def _trained_on(dataset: StudyDataset) -> dict:
    return {"dataset": str(dataset.path.resolve()), "scenario": dataset.scenario.model_dump(mode="json")}


def _same_data(trained_on: dict, dataset: StudyDataset) -> bool:
    """Whether a checkpoint's marker names this dataset and its scenario, read with today's schema (so a
    field added since, at its default, or a dump written by an older simgen still counts as the same)."""
    try:
        scenario = parse_scenario(trained_on["scenario"], TRAINED_ON)
    except (KeyError, TypeError, UserError):
        return False
    return trained_on.get("dataset") == str(dataset.path.resolve()) and scenario == dataset.scenario


def trained_model(
    options: StudyOptions, model: str, dataset: StudyDataset
) -> tuple[Detector, DetectorConfig, bool, float]:
    """(detector, config, reused, fit seconds): the checkpoint in OUT/<model>/ if it matches, else train.fit."""
    config, run = model_config(options, model), options.out / model
    path, marker = run / CHECKPOINT_NAME, run / TRAINED_ON
    start = time.perf_counter()
    reused = path.is_file() and marker.is_file() and _same_data(json.loads(marker.read_text()), dataset)
    if reused:
        checkpoint = load_checkpoint(path)
        reused = same_weights(checkpoint.config, config) and checkpoint.iteration == config.train.iterations
    if not reused:
        marker.unlink(missing_ok=True)
        fit(config, str(dataset.path), run, options.device, options.progress, overwrite=True)
        with atomic_path(marker) as tmp:
            tmp.write_text(json.dumps(_trained_on(dataset), sort_keys=True))
        checkpoint = load_checkpoint(path)
    detector = Detector(config)
    detector.load_state_dict(checkpoint.model)
    return detector, config, reused, time.perf_counter() - start


@dataclass(frozen=True)
class ClipSet:
    """A model's tracklets and the ground truth on some clips, per clip, frame for frame."""

    tracklets: dict[str, ClipTracklets]
    frames: dict[str, list[int]]  # frames t with two before them
    truth: dict[str, list[GroundTruthFrame]]

    def clip_frames(self, clip: str) -> list[Tracklets]:
        return [Tracklets(*self.tracklets[clip].at(f)) for f in self.frames[clip]]

    @property
    def clips(self) -> list[str]:
        return sorted(self.tracklets)


def clip_set(results: list[tuple[Sample, Detections]]) -> ClipSet:
    by_clip: dict[str, list[tuple[Sample, Detections]]] = {}
    for sample, detected in results:
        by_clip.setdefault(sample.clip, []).append((sample, detected))
    tracklets = {
        clip: clip_tracklets(clip, [s.index for s, _ in rows], [d.boxes for _, d in rows], [d.scores for _, d in rows])
        for clip, rows in by_clip.items()
    }
    frames = {clip: [s.index for s, _ in rows] for clip, rows in by_clip.items()}
    truth = {clip: truth_frames([s for s, _ in rows]) for clip, rows in by_clip.items()}
    return ClipSet(tracklets, frames, truth)


def truth_frames(samples: list[Sample]) -> list[GroundTruthFrame]:
    """A clip's ground truth for tracking, frame t of each sample in order (train.evaluation.truth)."""
    ids = TruthIds()
    return [ids.frame(sample.boxes[:, -1], sample.track_id, sample.placed) for sample in samples]


def tracklet_results(paths: list[Path], dataset: Path, config: DetectorConfig) -> list[tuple[Sample, Detections]]:
    """Tracklet files (train.detector.detections, one per clip) with their clips' ground truth from the dataset,
    as the study scores them: every frame t with two before it, the objects of `config`'s classes whose centre
    at t is in its point range (train.data.load_sample, crop); the samples without their points."""
    data = simgen.datasets.open(dataset)
    recent = RecentFrames(data)
    results: list[tuple[Sample, Detections]] = []
    clips: set[str] = set()
    for path in paths:
        found = read_tracklets(path)
        if found.clip not in data.clips:
            raise UserError(f"{path}: its clip {found.clip!r} is not in {dataset}")
        if found.clip in clips:
            raise UserError(f"{path}: a second tracklet file of clip {found.clip!r}")
        clips.add(found.clip)
        keys = list(range(TRACKLET_FRAMES - 1, data.num_frames(found.clip)))
        outside = np.setdiff1d(found.frame, keys)
        if len(outside):
            raise UserError(f"{path}: frame {outside[0]} is not a frame t of {found.clip!r} (2..{keys[-1]})")
        results += [(replace(crop(load_sample(recent, found.clip, t, config), config.data.point_range_m), points=()),
                     Detections(*found.at(t))) for t in keys]
    return results


def tracklet_clip_set(paths: list[Path], dataset: Path, config: DetectorConfig) -> ClipSet:
    """`tracklet_results` as a ClipSet, for the trackers."""
    return clip_set(tracklet_results(paths, dataset, config))


def detect_split(
    model: Detector, config: DetectorConfig, dataset: StudyDataset, split: str, options: StudyOptions
) -> list[tuple[Sample, Detections]]:
    """One inference pass over a split's clips; the samples without their points."""
    predicted = predict(model, config, str(dataset.path), split, options.device, options.progress)
    return [(replace(s, points=()), d) for s, d in predicted]


def detect_val(
    model: Detector, config: DetectorConfig, dataset: StudyDataset, options: StudyOptions
) -> tuple[list[ApRow], Decomposition, ClipSet]:
    """One inference pass over the val clips: AP rows (all boxes and visible ones), where the 3D AP of the
    boxes at t goes (train.evaluation.decomposition), tracklets and ground truth."""
    results = detect_split(model, config, dataset, "val", options)
    visible = visible_objects(simgen.datasets.open(dataset.path), [s for s, _ in results])
    at_t = [FrameBoxes(d.boxes[:, -1], d.scores, s.boxes[s.box_mask[:, -1], -1]) for s, d in results]
    decomposition = decompose(at_t, [v[s.box_mask[:, -1]] for v, (s, _) in zip(visible, results)])
    return average_precisions(results, visible), decomposition, clip_set(results)


def run_tracker(config: TrackerConfig, clips: ClipSet, rule: TrackletFilter | None) -> list[list[TrackedFrame]]:
    """Every clip through a fresh tracker, one output per frame; tracklets filtered by `rule` unless None."""
    frames = [clips.clip_frames(c) for c in clips.clips]
    return [track_clip(make_tracker(config), f if rule is None else apply_filter(f, rule)) for f in frames]


def tracklets_per_frame(clips: ClipSet, rule: TrackletFilter | None) -> float:
    frames = [f for c in clips.clips for f in clips.clip_frames(c)]
    kept = frames if rule is None else apply_filter(frames, rule)
    return sum(len(f.scores) for f in kept) / max(1, len(kept))


def choose_tracklet_filters(
    train: ClipSet, val: ClipSet, configs: list[TrackerConfig], progress: bool, workers: int = 1
) -> dict[str, FilterChoice]:
    """Each tracker's filter of train.study.tracklet_filter.GRID: the one it tracks best on the train clips
    (`workers` processes)."""
    clips = [train.clip_frames(c) for c in train.clips]
    chosen = choose_filters(clips, [train.truth[c] for c in train.clips], configs, progress=progress, workers=workers)
    frames, before = sum(len(c) for c in clips), tracklets_per_frame(val, None)
    return {name: FilterChoice(rule, name, scores, frames, (before, tracklets_per_frame(val, rule)))
            for name, (rule, scores) in chosen.items()}


def given_filters(val: ClipSet, configs: list[TrackerConfig], rules: dict[str, TrackletFilter],
                  source: str) -> dict[str, FilterChoice]:
    """Each tracker's filter as given (`rules`, by tracker name, from `source`), not chosen here."""
    missing = [c.name for c in configs if c.name not in rules]
    if missing:
        raise UserError(f"{source}: names no filter for tracker {missing[0]!r}")
    before = tracklets_per_frame(val, None)
    return {c.name: FilterChoice(rules[c.name], c.name, [], 0, (before, tracklets_per_frame(val, rules[c.name])))
            for c in configs}


def module_counts(
    val: ClipSet, configs: list[TrackerConfig], filters: dict[str, FilterChoice]
) -> dict[str, ModuleCounts]:
    """What birth/death and split do (train.evaluation.tracker_modules) for each tracker that has them, on the val
    clips through its own filter."""
    truth = [val.truth[c] for c in val.clips]
    return {
        config.name: count_modules(
            config, [apply_filter(val.clip_frames(c), filters[config.name].chosen) for c in val.clips], truth
        )
        for config in configs
        if config.life_cycle.birth_death or config.split
    }


def split_window_pairs(
    val: ClipSet, configs: list[TrackerConfig], filters: dict[str, FilterChoice]
) -> dict[str, ClosePairs]:
    """For each tracker with the split module, how its filtered val tracklets show the players close enough to
    split (train.evaluation.tracker_modules.close_pairs)."""
    return {
        config.name: sum(
            (close_pairs(apply_filter(val.clip_frames(c), filters[config.name].chosen), val.truth[c])
             for c in val.clips),
            ClosePairs(),
        )
        for config in configs
        if config.split
    }


def _scored(config: TrackerConfig, filtered: bool, truth: list, tracks: list) -> list[TrackerResult]:
    """A tracker's tracks on clips scored against their labels at each of MIN_IOUS, HOTA beside."""
    scores = (hota(truth, tracks), centre_hota(truth, tracks))
    return [TrackerResult(config.name, filtered, iou, evaluate_tracking(truth, tracks, min_iou=iou), *scores)
            for iou in MIN_IOUS]


def track(
    val: ClipSet, configs: list[TrackerConfig], filters: dict[str, FilterChoice], progress: bool, by_zone: bool = False
) -> tuple[list[TrackerResult], dict[str, list[TrackerResult]]]:
    """Table 2: every tracker on every val clip, tracklets filtered by its own filter and unfiltered, scored at each of
    MIN_IOUS; with `by_zone`, also Table 2 in each pitch zone (train.evaluation.zones, else {}): each tracker's tracks
    of its filtered tracklets and the labels cut, frame by frame, to the boxes whose centre is in the zone (zones with
    no labelled box left out). A player crossing the zone's edge leaves one zone's ground truth and enters the
    other's; a track box on one side of the edge and its player on the other count as a miss and a false positive."""
    truth = [val.truth[c] for c in val.clips]
    zone_truth = {zone: [truth_in_zone(clip, k) for clip in truth] for k, zone in enumerate(ZONES)} if by_zone else {}
    zone_truth = {z: t for z, t in zone_truth.items() if any(len(frame.ids) for clip in t for frame in clip)}
    results: list[TrackerResult] = []
    zoned: dict[str, list[TrackerResult]] = {zone: [] for zone in zone_truth}
    runs = [(config, filtered) for filtered in (True, False) for config in configs]
    for config, filtered in tqdm(runs, desc="track", unit="tracker", disable=not progress, dynamic_ncols=True):
        tracks = run_tracker(config, val, filters[config.name].chosen if filtered else None)
        results += _scored(config, filtered, truth, tracks)
        for zone, cut_truth in zone_truth.items() if filtered else ():
            zoned[zone] += _scored(config, True, cut_truth, [tracks_in_zone(c, ZONES.index(zone)) for c in tracks])
    return results, zoned


def run_study(options: StudyOptions, scenario: Scenario) -> StudyResult:
    """The whole study; writes OUT/<model>/ (checkpoint, log), OUT/late/tracklets/ and returns the numbers."""
    start = time.perf_counter()
    configs = load_tracker_configs(options.trackers)
    dataset = prepare_dataset(options.scenario, scenario, options.datasets, options.progress)
    detectors, tracked = [], None
    for model in options.models:
        detector, config, reused, fit_s = trained_model(options, model, dataset)
        began = time.perf_counter()
        rows, decomposition, detections = detect_val(detector, config, dataset, options)
        detectors.append(DetectorResult(model, config, reused, fit_s, time.perf_counter() - began, rows, decomposition))
        if model == TRACKED_MODEL:
            on_train = (
                clip_set(detect_split(detector, config, dataset, "train", options))
                if config.data.split == "clip"
                else None
            )
            tracked = (detections, on_train)
            (options.out / model / "tracklets").mkdir(parents=True, exist_ok=True)
            for clip, clip_rows in detections.tracklets.items():
                write_tracklets(options.out / model / "tracklets" / f"{clip}.npz", clip_rows)
    began = time.perf_counter()
    val, train = tracked
    filters, trackers = {}, []
    if detectors[0].config.data.split == "clip":  # the frame split's val windows are scattered: nothing to track
        workers = max(1, next(d.config for d in detectors if d.model == TRACKED_MODEL).train.workers)
        filters = choose_tracklet_filters(train, val, configs, options.progress, workers)
        trackers, _ = track(val, configs, filters, options.progress)
    now = time.perf_counter()
    return StudyResult(dataset, detectors, trackers, filters, now - began, now - start, options.device.type)
