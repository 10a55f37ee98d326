"""The tracking metrics of a run of any length in bounded memory: each frame's ground truth and tracks go to disk
as they become final, CHUNK_FRAMES frames a file, and the metrics are computed by passes over the files.

The values are those of train.evaluation.tracking.evaluate_tracking and train.evaluation.hota on the same
frames (the same per-frame matching, the same counts): only floating-point sums are grouped by chunk, so MOTP,
AMOTP and the HOTA parts may differ from theirs in the last bits. What memory keeps grows with the number of
identities (HOTA's alignment of every ground-truth and track id pair of a clip, each id's IDS/FRAG state, each
track's scores for its mean), not with the number of frames; the true positives' scores (8 bytes each) are kept
for AB3DMOT's recall thresholds.

A chunk file is an .npz of plain arrays (read without pickle): per frame the counts of ground-truth and tracker
boxes, then their boxes, ids, scores and states, and each frame's (G, T) 3D IoU, flattened. A frame without labels
is logged with no ground truth (a resumed `track` reads the tracks back to rebuild its outputs).
"""

from __future__ import annotations

import shutil
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from train.evaluation.hota import ClipCounts, Hota, Similarity, centre_similarity, combined
from train.evaluation.tracking import (
    RECALL_LEVELS,
    ClearMot,
    TrackingMetrics,
    _Counter,
    _Frame,
    _frame_ious,
    recall_thresholds,
)
from train.tracking.types import GroundTruthFrame, TrackedFrame

CHUNK_FRAMES = 100


@dataclass
class _Clip:
    chunks: int = 0
    gt_ids: set[int] = field(default_factory=set)
    scores: dict[int, array] = field(default_factory=dict)  # track id -> its scores, frame after frame


@dataclass(frozen=True)
class _LoggedFrame:
    truth: GroundTruthFrame
    tracked: TrackedFrame
    iou: NDArray[np.float64]  # (G, T)


def _states(tracked: TrackedFrame) -> NDArray[np.int8]:
    return tracked.states if tracked.states is not None else np.zeros(len(tracked.ids), np.int8)


class _Switches:
    """IDS and FRAG along every ground-truth trajectory, fed its frames in order (the rule of
    train.evaluation.tracking, whose last term needs the trajectory's next frame: held until it comes)."""

    def __init__(self) -> None:
        # (clip, gt id) -> [previous frame's id, last id seen, a fragment if the next frame is tracked, one if not]
        self.state: dict[tuple[int, int], list] = {}
        self.ids = self.frag = 0

    def see(self, key: tuple[int, int], assigned: int) -> None:
        """The tracker id matched to ground truth `key` in its next frame; -1: untracked."""
        state = self.state.get(key)
        if state is None:
            self.state[key] = [assigned, assigned, False, False]
            return
        previous, last, pending = state[:3]
        if pending and assigned != -1:
            self.frag += 1
        tracked = last != -1 and assigned != -1
        self.ids += tracked and assigned != last and previous != -1
        state[:] = [assigned, assigned if assigned != -1 else last, tracked and assigned != previous,
                    assigned != previous and assigned != -1]

    def counts(self) -> tuple[int, int]:
        """IDS and FRAG, every trajectory's frame seen so far taken as its last."""
        return self.ids, self.frag + sum(1 for s in self.state.values() if s[3])


class FrameLog:
    """A run's frames in `folder` (made here, removed by `remove`): clip after clip, `add` each frame in order."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.clips: list[_Clip] = []
        self._buffer: list[_LoggedFrame] = []
        self.gt_boxes = 0  # logged so far

    def start_clip(self) -> None:
        self.clips.append(_Clip())

    def add(self, truth: GroundTruthFrame | None, tracked: TrackedFrame) -> None:
        """The clip's next frame: its ground truth (None: no labels) and tracks."""
        truth = GroundTruthFrame(np.zeros((0, 7)), np.zeros(0, np.int64)) if truth is None else truth
        clip = self.clips[-1]
        clip.gt_ids.update(truth.ids.tolist())
        self.gt_boxes += len(truth.ids)
        for track, score in zip(tracked.ids.tolist(), tracked.scores.tolist()):
            clip.scores.setdefault(track, array("d")).append(score)
        self._buffer.append(_LoggedFrame(truth, tracked, np.zeros(0)))
        if len(self._buffer) == CHUNK_FRAMES:
            self._flush()

    def end_clip(self) -> None:
        self._flush()

    def _flush(self) -> None:
        if not self._buffer:
            return
        frames, self._buffer = self._buffer, []
        truth, tracked = [f.truth for f in frames], [f.tracked for f in frames]
        iou = _frame_ious(truth, tracked)
        clip = self.clips[-1]
        np.savez(self.folder / f"{len(self.clips) - 1:04d}_{clip.chunks:06d}.npz",
                 gt_count=[len(t.ids) for t in truth], track_count=[len(t.ids) for t in tracked],
                 gt_boxes=np.concatenate([t.boxes for t in truth]), gt_ids=np.concatenate([t.ids for t in truth]),
                 track_boxes=np.concatenate([t.boxes for t in tracked]),
                 track_ids=np.concatenate([t.ids for t in tracked]),
                 track_scores=np.concatenate([t.scores for t in tracked]),
                 track_states=np.concatenate([_states(t) for t in tracked]),
                 iou=np.concatenate([m.ravel() for m in iou]))
        clip.chunks += 1

    def chunks(self, clip: int) -> Iterator[list[_LoggedFrame]]:
        """The clip's frames, a chunk at a time, read back."""
        for k in range(self.clips[clip].chunks):
            with np.load(self.folder / f"{clip:04d}_{k:06d}.npz", allow_pickle=False) as data:
                parts = {name: data[name] for name in data.files}
            gt_ends, track_ends = np.cumsum(parts["gt_count"]), np.cumsum(parts["track_count"])
            iou_ends = np.cumsum(parts["gt_count"] * parts["track_count"])
            frames = []
            for g1, t1, i1, g, t in zip(gt_ends, track_ends, iou_ends, parts["gt_count"], parts["track_count"]):
                g0, t0, i0 = g1 - g, t1 - t, i1 - g * t
                frames.append(_LoggedFrame(
                    GroundTruthFrame(parts["gt_boxes"][g0:g1], parts["gt_ids"][g0:g1]),
                    TrackedFrame(parts["track_boxes"][t0:t1], parts["track_ids"][t0:t1], parts["track_scores"][t0:t1],
                                 (), parts["track_states"][t0:t1]),
                    parts["iou"][i0:i1].reshape(g, t)))
            yield frames

    def state(self) -> dict[str, NDArray]:
        """What `restore` needs, as plain arrays, the current clip's chunks all written (at a chunk's end)."""
        if self._buffer:
            raise ValueError("a frame log's state is taken between chunks")
        scores = [(c, track, s) for c, clip in enumerate(self.clips) for track, s in clip.scores.items()]
        return {
            "log_chunks": np.array([c.chunks for c in self.clips], np.int64),
            "log_gt_clip": np.concatenate([np.full(len(c.gt_ids), k) for k, c in enumerate(self.clips)] or [[]]),
            "log_gt_ids": np.array([i for c in self.clips for i in sorted(c.gt_ids)], np.int64),
            "log_track_clip": np.array([c for c, _, _ in scores], np.int64),
            "log_track_ids": np.array([t for _, t, _ in scores], np.int64),
            "log_track_lengths": np.array([len(s) for _, _, s in scores], np.int64),
            "log_scores": np.concatenate([np.frombuffer(s) for _, _, s in scores] or [np.zeros(0)]),
            "log_gt_boxes": np.array(self.gt_boxes),
        }

    def restore(self, state: dict[str, NDArray]) -> None:
        """Back to a `state` of a log in the same folder: chunk files after it removed."""
        self.clips = [_Clip(int(n)) for n in state["log_chunks"]]
        for clip, ids in zip(state["log_gt_clip"].tolist(), state["log_gt_ids"].tolist()):
            self.clips[int(clip)].gt_ids.add(ids)
        ends = np.cumsum(state["log_track_lengths"])
        for clip, track, end, n in zip(state["log_track_clip"].tolist(), state["log_track_ids"].tolist(),
                                       ends.tolist(), state["log_track_lengths"].tolist()):
            self.clips[clip].scores[track] = array("d", state["log_scores"][end - n:end].tolist())
        self.gt_boxes = int(state["log_gt_boxes"])
        kept = {f"{c:04d}_{k:06d}.npz" for c, clip in enumerate(self.clips) for k in range(clip.chunks)}
        for path in self.folder.glob("*.npz"):
            if path.name not in kept:
                path.unlink()
        self._buffer = []

    def remove(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)

    def mean_scores(self, clip: int) -> dict[int, float]:
        return {track: float(np.mean(np.frombuffer(s))) for track, s in self.clips[clip].scores.items()}

    def clear_mot(self, threshold: float, means: list[dict[int, float]], min_iou: float, scores: bool = False
                  ) -> tuple[ClearMot, NDArray[np.float64] | None]:
        """CLEAR MOT counts over every frame with the tracks whose mean score is at least threshold, and with
        `scores` the true positives' scores (train.evaluation.tracking's _Counter, chunk by chunk)."""
        switches = _Switches()
        n_gt = tp = kept_total = 0
        iou_sum, tp_scores = 0.0, []
        for c in range(len(self.clips)):
            for frames in self.chunks(c):
                count = _Counter([[_Frame(f.truth.ids, f.tracked.ids, f.iou,
                                          np.array([means[c][k] for k in f.tracked.ids.tolist()]))
                                   for f in frames]], min_iou)
                keep, gt_slots, track_slots, chunk_iou = count.matches(threshold)
                assigned = np.full(count.gt_start[-1], -1, np.int64)
                assigned[gt_slots] = count.track_ids[track_slots]
                for gt, track in zip(np.concatenate([f.truth.ids for f in frames]).tolist(), assigned.tolist()):
                    switches.see((c, gt), track)
                n_gt += int(count.gt_start[-1])
                tp += len(gt_slots)
                kept_total += int(keep.sum())
                iou_sum += chunk_iou
                if scores:
                    tp_scores.append(count.track_scores[track_slots])
        ids, frag = switches.counts()
        counts = ClearMot(n_gt, tp, kept_total - tp, n_gt - tp, ids, frag, iou_sum)
        return counts, np.concatenate([np.zeros(0), *tp_scores]) if scores else None

    def evaluate_tracking(self, min_iou: float = 0.25, levels: int = RECALL_LEVELS) -> TrackingMetrics:
        """train.evaluation.tracking.evaluate_tracking of the logged frames."""
        means = [self.mean_scores(c) for c in range(len(self.clips))]
        everything, tp_scores = self.clear_mot(-np.inf, means, min_iou, scores=True)
        samota = amota = amotp = 0.0
        best_mota, best_threshold = 0.0, -np.inf
        thresholds = recall_thresholds(tp_scores, everything.n_gt, levels) if everything.n_gt else []
        for threshold, recall in thresholds:
            counts, _ = self.clear_mot(threshold, means, min_iou)
            samota, amota, amotp = samota + counts.smota(recall), amota + counts.mota, amotp + counts.motp
            if counts.mota > best_mota:
                best_mota, best_threshold = counts.mota, threshold
        best = everything if best_threshold == -np.inf else self.clear_mot(best_threshold, means, min_iou)[0]
        return TrackingMetrics(samota / levels, amota / levels, amotp / levels, best, best_threshold, len(thresholds))

    def hota(self, similarity: Similarity | None = None) -> Hota:
        """train.evaluation.hota.hota of the logged frames: 3D IoU, or `similarity` of their boxes."""
        counts = []
        for c, clip in enumerate(self.clips):
            gt_ids = np.array(sorted(clip.gt_ids), np.int64)
            track_ids = np.array(sorted(clip.scores), np.int64)
            clip_counts = ClipCounts(len(gt_ids), len(track_ids))

            def frames(c: int = c, gt_ids: NDArray = gt_ids, track_ids: NDArray = track_ids) -> Iterator[tuple]:
                for chunk in self.chunks(c):
                    for f in chunk:
                        sim = f.iou if similarity is None else similarity(f.truth.boxes, f.tracked.boxes)
                        yield sim, np.searchsorted(gt_ids, f.truth.ids), np.searchsorted(track_ids, f.tracked.ids)

            for frame in frames():
                clip_counts.align(*frame)
            clip_counts.aligned()
            for frame in frames():
                clip_counts.match(*frame)
            counts.append(clip_counts.counts())
        return combined(counts)

    def centre_hota(self) -> Hota:
        return self.hota(centre_similarity)

