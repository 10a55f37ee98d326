"""`simgen-train track`: detections from one source -> the tracker a YAML names -> tracks on disk and, where there
are labels, the paper's metrics.

Sources (exactly one): a checkpoint (our detector on the frames, train.detector.streaming), tracklet files of
`simgen-train detect`, or KITTI object files with a score (train.track.detections). Frames come from a
dataset's clips of a split or from a ROS 2 MCAP bag (train.track.frames), one at a time in time order.

Offline, a checkpoint's detector first runs over the whole split (train.detector.inference.predict), then
each clip is tracked. Online (`online`), each frame goes through reading, pillars, network, decoding and
tracking before the next is read, nothing ever looking ahead, paced at `rate_hz` if given
(train.track.latency); the two give the same tracks. Either way a track's boxes are final two frames after
its frame (a track confirmed later back-fills them: train.tracking.clip.HeldFrames), and are then
written (train.track.outputs).

Before tracking, the tracklets pass a score threshold and a greedy NMS on centre distance
(train.study.tracklet_filter): by default score >= 0.2 and centres >= 1 m apart, the filter the study
chose for the full tracker on paper_x1 (studies/paper_x1_1200/table2.md).

Ground truth (train.evaluation.truth): the labelled objects of the detector's classes whose centre lies
in its point range (the checkpoint's config; every labelled object for other sources), on the frames
tracked.
"""

from __future__ import annotations

import time
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

import simgen.datasets
from simgen.datasets.formats.mcap import SIMGEN_LAYOUT, XYZI_LAYOUT
from simgen.datasets.frame import Frame
from simgen.errors import UserError
from train.config import TRACKLET_FRAMES, DataConfig, DetectorConfig
from train.data import Sample, crop, encode_sample, frame_points, load_sample
from train.detector.folding import fold_batchnorm
from train.detector.inference import predict
from train.detector.model import Detector
from train.detector.postprocess import tracklets as decode_tracklets
from train.detector.streaming import WindowFeatures, head
from train.evaluation.frame_log import CHUNK_FRAMES, FrameLog
from train.evaluation.hota import Hota
from train.evaluation.tracking import TrackingMetrics
from train.evaluation.truth import TruthIds
from train.study.tracklet_filter import TrackletFilter, filter_tracklets
from train.track import resume
from train.track.detections import KittiClip, TrackletClip, as_tracklets
from train.track.frames import BagFrames, Labels, Window, frame_labels
from train.track.latency import LatencyLog, Pacer, Stopwatch
from train.track.outputs import TrackOutputs, staged
from train.tracking.clip import HeldFrames, make_tracker
from train.tracking.config import TrackerConfig
from train.tracking.types import GroundTruthFrame, TrackedFrame, Tracklets

DEFAULT_FILTER = TrackletFilter(0.2, "centre", 1.0)
DEFAULT_TRACKER = "5_diou_birth_death_split.yaml"  # in train/configs/tracking/: the paper's full tracker
MIN_IOU = 0.25  # AB3DMOT's 3D IoU of a true positive


@dataclass(frozen=True)
class Model:
    detector: Detector
    config: DetectorConfig


@dataclass(frozen=True)
class TrackOptions:
    out: Path
    tracker: TrackerConfig
    dataset: str | None  # a dataset folder, or None with `bag`
    bag: Path | None
    ros2_layout: str  # the bag's point layout: simgen or livox
    model: Model | None  # exactly one of model, tracklets, detections
    tracklets: Path | None
    detections: Path | None
    split: str | None  # train, val or None (all)
    online: bool
    rate_hz: float | None
    queue: int
    rule: TrackletFilter | None  # None: the tracklets as they are
    device: torch.device
    progress: bool
    clock: Callable[[], float] = time.perf_counter  # of the stage latencies (wall time)
    resume: bool = False  # go on from an interrupted run's state in OUT (offline, from a dataset)
    rerun: Path | None = None  # a Rerun recording of points, labels and tracks (train.track.rerun_tracks)


@dataclass(frozen=True)
class TrackResult:
    clips: list[str]
    frames: int  # tracked
    tracks: int  # distinct (clip, track id)
    play_s: float  # game time the tracked frames span, clip by clip
    seconds: float
    metrics: TrackingMetrics | None  # None: no labels
    hota: Hota | None
    centre_hota: Hota | None
    late: int
    dropped: int
    latency: LatencyLog | None  # online only


def _detection_folders(folder: Path, dataset: simgen.datasets.Dataset, clips: list[str], suffix: str) -> list[str]:
    """The clips of `clips` that `folder` holds detections of (`<clip>` + suffix); one of another clip is an error."""
    if not folder.is_dir():
        raise UserError(f"{folder}: not a folder")
    found = {p.name.removesuffix(suffix) for p in folder.iterdir() if p.name.endswith(suffix) or not suffix}
    unknown = sorted(found - set(dataset.clips))
    if unknown:
        raise UserError(f"{folder / (unknown[0] + suffix)}: clip {unknown[0]!r} is not in {dataset.root}")
    chosen = [c for c in clips if c in found]
    if not chosen:
        raise UserError(f"{folder}: no detections of the split's clips ({', '.join(clips[:3])}...)")
    return chosen


class _Detector:
    """Our detector one frame at a time (online): the stages timed apart on a Stopwatch."""

    def __init__(self, model: Model, device: torch.device) -> None:
        self.config, self.device = model.config, device
        self.folded = fold_batchnorm(model.detector).to(device)
        self.windows = WindowFeatures(self.folded, self.config, device)
        self._warm_up()

    def _warm_up(self) -> None:
        """One window of made-up points through the network before the first frame arrives (a sensor's first
        frame should not pay for the libraries' lazy set-up)."""
        x0, y0, z0, x1, y1, z1 = self.config.data.point_range_m
        point = np.array([[(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2, 0.5]], np.float32)
        inputs = self.config.model.fusion.input_frames
        nothing = np.zeros((0, TRACKLET_FRAMES, 7), np.float32)
        sample = Sample("warm-up", TRACKLET_FRAMES - 1, (point,) * inputs, nothing,
                        np.zeros((0, TRACKLET_FRAMES), bool), np.zeros(0, np.int64), np.zeros(0, bool))
        windows = WindowFeatures(self.folded, self.config, self.device)
        with torch.inference_mode():
            decode_tracklets(*head(self.folded, self.config, windows.fuse(*windows.pillars(
                encode_sample(sample, self.config)))), self.folded.head.anchors, self.config)

    def prime(self, frame: Frame, watch: Stopwatch) -> None:
        """A frame before the clip's first window: its canvas computed as it arrives, for the windows to come."""
        points = frame_points(frame)
        nothing = np.zeros((0, TRACKLET_FRAMES, 7), np.float32)
        sample = Sample(frame.clip, frame.index, (points,), nothing, np.zeros((0, TRACKLET_FRAMES), bool),
                        np.zeros(0, np.int64), np.zeros(0, bool))
        encoded = encode_sample(crop(sample, self.config.data.point_range_m), self.config)
        watch.lap("pillars")
        with torch.inference_mode():
            self.windows.keep(encoded)
        watch.lap("network")

    def __call__(self, window: Window, clip: str, index: int, watch: Stopwatch) -> Tracklets:
        sample = crop(load_sample(window, clip, index, self.config), self.config.data.point_range_m)
        encoded = encode_sample(sample, self.config)
        prepared = self.windows.pillars(encoded)
        watch.lap("pillars")
        with torch.inference_mode():
            outputs = head(self.folded, self.config, self.windows.fuse(*prepared))
            if self.device.type == "cuda":
                torch.cuda.synchronize()
            watch.lap("network")
            found = decode_tracklets(*outputs, self.folded.head.anchors, self.config)
        return as_tracklets(found.boxes, found.scores)


class _Truth:
    """A clip's ground truth, frame after frame: the labels of the detector's classes (in its range)."""

    def __init__(self, data: DataConfig, in_range: bool) -> None:
        self.classes, self.ids = np.array(data.classes), TruthIds()
        self.range = np.asarray(data.point_range_m) if in_range else None

    def frame(self, labels: Labels) -> GroundTruthFrame:
        keep = np.isin(labels.class_name, self.classes)
        if self.range is not None:
            centre = labels.boxes[:, :2]
            keep &= np.all((centre >= self.range[:2]) & (centre < self.range[3:5]), axis=1)
        return self.ids.frame(labels.boxes[keep], labels.track_id[keep].astype(np.int64), labels.placed[keep])


def _filtered(tracklets: Tracklets, rule: TrackletFilter | None) -> Tracklets:
    if rule is None:
        return tracklets
    kept = filter_tracklets(tracklets.boxes, tracklets.scores, rule)
    return Tracklets(tracklets.boxes[kept], tracklets.scores[kept])


def _empty() -> Tracklets:
    return Tracklets(np.zeros((0, 3, 7)), np.zeros(0))


class _Run:
    """One `track` run: its inputs opened and checked, then `clips` tracked into `outputs`."""

    def __init__(self, options: TrackOptions) -> None:
        self.options = options
        self.bag = BagFrames(options.bag, options.ros2_layout) if options.bag is not None else None
        if self.bag is not None:
            self.dataset, self.clips, self.root = None, [self.bag.clip], options.bag
            self.sensors, self.layout = [], XYZI_LAYOUT
        else:
            self.dataset = simgen.datasets.open(options.dataset)
            self.root = self.dataset.root
            split = options.split
            self.clips = [c for c in self.dataset.clips if split is None or self.dataset.split(c) == split]
            if not self.clips:
                raise UserError(f"{self.root}: no clips in the {options.split!r} split")
            if options.online:  # every file's checksum before the first frame arrives, not while it is read
                self.dataset.verify()
            self.sensors = list(self.dataset.manifest.sensors)
            self.layout = SIMGEN_LAYOUT if self.dataset.plugin.carries.point_fields else XYZI_LAYOUT
        # each clip's detections by frame: KITTI files and tracklet files read as the frames come (flat memory)
        self.found: dict[str, dict[int, Tracklets] | KittiClip | TrackletClip] = {}
        if options.detections is not None:
            self.clips = _detection_folders(options.detections, self.dataset, self.clips, "")
            self.found = {c: KittiClip(options.detections / c, self.dataset.num_frames(c)) for c in self.clips}
        elif options.tracklets is not None:
            self.clips = _detection_folders(options.tracklets, self.dataset, self.clips, ".npz")
            self.found = {c: TrackletClip(options.tracklets / f"{c}.npz", c, self.dataset.num_frames(c))
                          for c in self.clips}
        model = options.model
        self.first = TRACKLET_FRAMES - 1 if model is not None or options.tracklets is not None else 0
        self.truth_data = model.config.data if model is not None else DataConfig()
        frames = self.bag.count if self.bag is not None else sum(self.dataset.num_frames(c) for c in self.clips)
        self.pacer = Pacer(options.rate_hz if options.online else None, options.queue, frames)
        self.latency = LatencyLog() if options.online else None
        self.k = 0  # frames delivered so far, clip after clip
        self.play_s = 0.0  # game time of the frames tracked (their count x their period), clip after clip
        self.detector = _Detector(model, options.device) if model is not None and (options.online or self.bag) else None
        self.resumable = not options.online and self.bag is None  # a state saved every chunk (train.track.resume)
        self.staging: Path | None = None

    def frames(self, clip: str, window: Window, start: int = 0) -> Iterator[tuple[Frame, bool, Stopwatch]]:
        """The clip's frames in order from `start`, each read once it arrives (`Pacer`) and added to the window:
        (frame, whether it was taken rather than dropped, its stopwatch with the read charged)."""
        source = self.bag.frames() if self.bag is not None else iter(range(start, self.dataset.num_frames(clip)))
        while True:
            taken = self.pacer.wait(self.k)
            watch = Stopwatch(self.options.clock)
            item = next(source, None)
            if item is None:
                return
            frame = window.add(item) if self.bag is not None else window.frame(clip, item)
            watch.lap("read")
            yield frame, taken, watch
            self.k += 1

    def labels(self, frame: Frame) -> Labels | None:
        return self.bag.labels.get(frame.index) if self.bag is not None else frame_labels(frame)

    def total_frames(self) -> int | None:
        if self.bag is not None:
            return None
        return sum(max(0, self.dataset.num_frames(c) - self.first) for c in self.clips)

    def offline_detections(self) -> None:
        """The checkpoint's tracklets of every frame of the split (offline), before any tracking."""
        model, options = self.options.model, self.options
        for sample, found in predict(model.detector, model.config, str(self.root), options.split, options.device,
                                     options.progress):
            if sample.clip in self.clips:
                self.found.setdefault(sample.clip, {})[sample.index] = as_tracklets(found.boxes, found.scores)

    def fingerprint(self) -> dict:
        """What a resumed run must share with the interrupted one (JSON)."""
        o = self.options
        return {"dataset": str(self.root), "clips": self.clips, "tracker": o.tracker.model_dump(mode="json"),
                "source": [str(o.tracklets), str(o.detections), o.model is not None], "first": self.first,
                "rule": None if o.rule is None else [o.rule.min_score, o.rule.nms, o.rule.nms_threshold],
                "resumable": self.resumable}

    def run(self, outputs: TrackOutputs, log: FrameLog, resumed: tuple[dict, dict] | None) -> None:
        """Track every clip into `outputs`, their ground truth and tracks into `log` (the metrics need them while
        every frame has labels: `labelled`); from the state of an interrupted run if `resumed`."""
        progress = tqdm(total=self.total_frames(), desc=f"track {self.options.tracker.name}", unit="frame",
                        disable=not self.options.progress, dynamic_ncols=True)
        self.labelled, self.tracked, self.track_ids, first_clip = True, 0, 0, 0
        if resumed is not None:
            meta, arrays = resumed
            self.labelled, self.tracked, self.track_ids = meta["labelled"], meta["tracked"], meta["track_ids"]
            self.k, self.play_s, first_clip = meta["k"], meta["play_s"], meta["clip"]
            log.restore(arrays)
            outputs.clips = first_clip
            progress.update(sum(max(0, self.dataset.num_frames(c) - self.first) for c in self.clips[:first_clip])
                            + max(0, meta["next"] - self.first))
        for c in range(first_clip, len(self.clips)):
            going_on = resumed is not None and c == first_clip and resumed[0]["next"] > 0
            self.clip(c, outputs, log, progress, resumed if going_on else None)
        progress.close()

    def checkpoint(self, log: FrameLog, clip: int, next_index: int, delivered: int, arrays: dict) -> None:
        """The run's state (train.track.resume) at the end of a chunk of clip `clip`: `next_index` the next frame to
        track (0: the clip has not started), `delivered` the frames delivered before it."""
        if self.resumable:
            meta = {"options": self.fingerprint(), "clip": clip, "next": next_index, "k": delivered,
                    "tracked": self.tracked, "track_ids": self.track_ids, "play_s": self.play_s,
                    "labelled": self.labelled}
            resume.save(self.staging, meta, {**log.state(), **arrays})

    def clip(self, c: int, outputs: TrackOutputs, log: FrameLog, progress: tqdm,
             resumed: tuple[dict, dict] | None = None) -> None:
        """Clip `c` through a fresh tracker (or one restored: `resumed`), its final frames written and logged."""
        clip = self.clips[c]
        tracker, held = make_tracker(self.options.tracker), HeldFrames()
        ids = _Truth(self.truth_data, self.options.model is not None)
        track_ids: set[int] = set()
        times = array("d")  # 8 bytes a frame, for the median period
        window = Window(Path(self.root), None if self.dataset is None else self.dataset.frame)

        def final(done: list[tuple[Frame, TrackedFrame]], log_it: bool = True) -> None:
            for frame, tracked in done:
                outputs.add(frame, tracked)
                if log_it:
                    labels = self.labels(frame)
                    self.labelled &= labels is not None
                    log.add(ids.frame(labels) if self.labelled else None, tracked)
                track_ids.update(tracked.ids.tolist())
                times.append(frame.label_time_s)

        def state() -> dict:
            held_frames = [tracked for _, tracked in held.frames]
            return {**tracker.state(), **ids.ids.state(), "clip_times": np.frombuffer(times),
                    "clip_track_ids": np.array(sorted(track_ids), np.int64),
                    "held_index": np.array([frame.index for frame, _ in held.frames], np.int64),
                    "held_count": np.array([len(t.ids) for t in held_frames], np.int64),
                    "held_boxes": np.concatenate([t.boxes for t in held_frames] or [np.zeros((0, 7))]),
                    "held_ids": np.concatenate([t.ids for t in held_frames] or [np.zeros(0, np.int64)]),
                    "held_scores": np.concatenate([t.scores for t in held_frames] or [np.zeros(0)]),
                    "held_states": np.concatenate([t.states for t in held_frames] or [np.zeros(0, np.int8)])}

        outputs.start_clip(clip)
        start = 0
        if resumed is None:
            log.start_clip()
        else:  # the interrupted clip's outputs again from its logged tracks, then its tracker as it was
            meta, arrays = resumed
            start = meta["next"]
            for chunk in log.chunks(c):
                for logged in chunk:
                    final([(window.frame(clip, self.first + len(times)), logged.tracked)], log_it=False)
            tracker.restore(arrays)
            ids.ids.restore(arrays)
            track_ids, times = set(arrays["clip_track_ids"].tolist()), array("d", arrays["clip_times"].tolist())
            ends = np.cumsum(arrays["held_count"])
            held.frames = [(window.frame(clip, index), TrackedFrame(
                arrays["held_boxes"][end - n:end], arrays["held_ids"][end - n:end], arrays["held_scores"][end - n:end],
                (), arrays["held_states"][end - n:end]))
                for index, end, n in zip(arrays["held_index"].tolist(), ends.tolist(), arrays["held_count"].tolist())]
        for frame, taken, watch in self.frames(clip, window, start):
            if frame.index < self.first:
                if self.detector is not None and taken:
                    self.detector.prime(frame, watch)
                    if self.latency is not None:
                        self.latency.add(clip, frame.index, watch)
                continue
            if taken:
                if self.detector is not None:
                    tracklets = self.detector(window, clip, frame.index, watch)
                else:
                    tracklets = self.found.get(clip, {}).get(frame.index, _empty())
                watch.lap("decode")
                out = tracker.step(_filtered(tracklets, self.options.rule))
                watch.lap("track")
                self.pacer.done(self.k)
                if self.latency is not None:
                    self.latency.add(clip, frame.index, watch)
                done = held.push(frame, out)
                final(done)
                if done and len(times) % CHUNK_FRAMES == 0:
                    self.checkpoint(log, c, frame.index + 1, self.k + 1, state())
            progress.update()
        final(held.flush())
        outputs.end_clip()
        log.end_clip()
        self.tracked += len(times)
        self.track_ids += len(track_ids)
        self.play_s += len(times) * float(np.median(np.diff(times))) if len(times) > 1 else 0.0
        self.checkpoint(log, c + 1, 0, self.k, {})


def run_track(options: TrackOptions, write: Callable[[Path, TrackResult], None]) -> TrackResult:
    """The whole run: inputs checked, every clip tracked and written, `write(folder, result)` adding the metrics'
    files where there are labels (OUT's files replaced only at the end)."""
    start = time.perf_counter()
    run = _Run(options)
    if options.model is not None and run.detector is None:
        run.offline_detections()
    with staged(options.out, options.resume) as staging:
        run.staging = staging
        resumed = resume.load(staging, run.fingerprint()) if options.resume else None
        from train.track.rerun_tracks import RerunTracks  # rerun and the drawing stack (numba) only when asked

        recording = None if options.rerun is None else RerunTracks(
            options.rerun, run.sensors, f"{Path(run.root).resolve().name}.track")
        outputs = TrackOutputs(staging, run.sensors, run.layout, bags=True, recording=recording)
        try:
            result = _finish(run, options, staging, outputs, resumed, start, write)
        except BaseException:
            if recording is not None:
                recording.abort()
            raise
        if recording is not None:
            recording.close()
    return result


def _finish(run: _Run, options: TrackOptions, staging: Path, outputs: TrackOutputs, resumed, start: float,
            write: Callable[[Path, TrackResult], None]) -> TrackResult:
    """Every clip tracked into `outputs`, then the metrics from the frame log, into `staging`."""
    log = FrameLog(staging / ".frames")  # the metrics' inputs and the tracks, on disk: flat memory, resumable
    run.run(outputs, log, resumed)
    outputs.close()
    resume.remove(staging)
    if run.latency is not None:
        run.latency.write(staging / "latency.csv")
    scores = None
    if run.labelled and log.gt_boxes:
        scores = (log.evaluate_tracking(MIN_IOU), log.hota(), log.centre_hota())
    log.remove()
    result = TrackResult(
        run.clips, run.tracked, run.track_ids, run.play_s, time.perf_counter() - start,
        *(scores or (None, None, None)), run.pacer.late, run.pacer.dropped, run.latency,
    )
    if scores is not None:
        write(staging, result)
    return result
