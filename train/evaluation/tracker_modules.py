"""What the tracker's birth/death and split modules do on a clip, counted against its labels.

The tracker (train.tracking.tracker) is stepped frame by frame and its track table read after each step. Every
live track's current box (a matched track's tracklet box at t, an unmatched one's Kalman prediction) is given the
label it overlaps most, at 3D IoU >= ``MIN_IOU`` (AB3DMOT's true-positive rule), or none. A label is *held* in a
frame by the confirmed tracks matched in it. Then:

- Births held back: tentative tracks that die before they are confirmed. *False*: no box of theirs on any
  label; *duplicate*: only on labels held by another track at that frame; *real*: on a label no track held,
  a player the birth rule kept from the output.
- Births confirmed: tentative tracks confirmed, with the same three kinds at the frame they are confirmed.
- Dying tracks (confirmed, unmatched, output at their prediction): each output frame is *useful* when its
  box is on a label no matched track holds, a *duplicate* when on a label one holds, *off* when on none (the
  last two false positives). A dying track that is matched again is
  *recovered*: on the label it had at its last match (*same*), on another (*other*: an identity carried to
  another player), or with no label at either end (*unlabelled*); one that runs out of frames *dies*.
- Splits: each pair of tracks the split module gave two boxes, per frame: *two players* when the two boxes
  lie on two different labels, *one player* when on one label (or one on a label, one on none), *none*
  otherwise.

What the split module is for, in the tracklets themselves (``close_pairs``): pairs of labelled players within
its window (centres 0.25-1.5 m apart at t), each *separate* (both on tracklets of their own), *fused* (one
tracklet, on one of them, whose centre is nearer their midpoint than that player's: the paper's Fig. 4), *one*
(one found, no fusion) or *none*.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from train.geometry import iou_3d
from train.tracking.config import TrackerConfig
from train.tracking.life_cycle import confirmed
from train.tracking.split import SplitConfig
from train.tracking.tracker import Tracker
from train.tracking.types import GroundTruthFrame, Tracklets

MIN_IOU = 0.25
_Counts = TypeVar("_Counts")
_NONE = -1


def _add_counts(a: _Counts, b: _Counts) -> _Counts:
    """Two dataclasses of counts of one type, field by field."""
    return type(a)(**{f.name: getattr(a, f.name) + getattr(b, f.name) for f in fields(a)})


@dataclass(frozen=True)
class ModuleCounts:
    """Counts over clips (see the module's docstring for each kind)."""

    held_back: int = 0
    held_back_false: int = 0
    held_back_duplicate: int = 0
    held_back_real: int = 0
    confirmed: int = 0
    confirmed_false: int = 0
    confirmed_duplicate: int = 0
    confirmed_real: int = 0
    dying_output: int = 0  # frames a dying track was output
    dying_output_useful: int = 0
    dying_output_duplicate: int = 0
    dying_output_off: int = 0
    dying_recovered: int = 0
    recovered_same: int = 0
    recovered_other: int = 0
    recovered_unlabelled: int = 0
    dying_died: int = 0
    splits: int = 0  # pair-frames
    split_two_players: int = 0
    split_one_player: int = 0
    split_none: int = 0

    __add__ = _add_counts


def box_labels(boxes: NDArray[np.float64], truth: GroundTruthFrame) -> NDArray[np.int64]:
    """(K,) the label id each box (K, 7) overlaps most at 3D IoU >= MIN_IOU, -1 where none."""
    if not len(boxes) or not len(truth.ids):
        return np.full(len(boxes), _NONE, np.int64)
    iou = iou_3d(boxes, truth.boxes)
    best = iou.argmax(axis=1)
    return np.where(iou[np.arange(len(boxes)), best] >= MIN_IOU, truth.ids[best], _NONE)


def _birth_kind(labels: list[tuple[int, frozenset[int]]]) -> str:
    """false / duplicate / real of a new track from its (label, labels held by others) per frame."""
    on = [(label, held) for label, held in labels if label != _NONE]
    if not on:
        return "false"
    return "duplicate" if all(label in held for label, held in on) else "real"


def count_clip(tracker: Tracker, frames: Sequence[Tracklets], truth: Sequence[GroundTruthFrame]) -> ModuleCounts:
    """One clip through a fresh `tracker`, its modules counted against `truth` (one labelled frame per frame)."""
    if len(frames) != len(truth):
        raise ValueError(f"{len(frames)} frames of tracklets and {len(truth)} of labels")
    counts: dict[str, int] = {}

    def add(name: str) -> None:
        counts[name] = counts.get(name, 0) + 1

    life = tracker.config.life_cycle
    births: dict[int, list[tuple[int, frozenset[int]]]] = {}  # tentative track -> (label, held by others) per frame
    last_label: dict[int, int] = {}  # confirmed track -> its label at its last match
    dying: set[int] = set()
    previous: set[int] = set()
    for tracklets, labelled in zip(frames, truth):
        tracker.step(tracklets)
        table = tracker.tracks
        ids = table.ids.tolist()
        labels = box_labels(table.boxes[:, -1], labelled)
        sure = confirmed(table.hits, life)
        matched = table.misses == 0
        holders = {i: int(label) for i, label, ok in zip(ids, labels, sure & matched) if ok and label != _NONE}
        for gone in previous - set(ids):
            if gone in births:
                add("held_back")
                add(f"held_back_{_birth_kind(births.pop(gone))}")
            if gone in dying:
                add("dying_died")
                dying.discard(gone)
        for track, label, is_sure, is_matched in zip(ids, labels.tolist(), sure, matched):
            held_by_others = frozenset(v for k, v in holders.items() if k != track)
            if not is_sure:
                births.setdefault(track, []).append((label, held_by_others))
                continue
            if track in births:  # confirmed in this frame
                add("confirmed")
                add(f"confirmed_{_birth_kind(births.pop(track)[-1:])}")
            if not is_matched:
                dying.add(track)
                add("dying_output")
                add("dying_output_off" if label == _NONE else
                    "dying_output_duplicate" if label in held_by_others else "dying_output_useful")
                continue
            if track in dying:
                dying.discard(track)
                add("dying_recovered")
                before = last_label.get(track, _NONE)
                add("recovered_unlabelled" if _NONE in (before, label) else
                    "recovered_same" if before == label else "recovered_other")
            last_label[track] = label
        row = dict(zip(ids, labels.tolist()))
        for pair in tracker.split_pairs:
            a, b = (row[i] for i in sorted(pair))
            add("splits")
            add("split_two_players" if _NONE not in (a, b) and a != b else
                "split_none" if a == b == _NONE else "split_one_player")
        previous = set(ids)
    return ModuleCounts(**counts)


def count_modules(
    config: TrackerConfig, clips: Sequence[Sequence[Tracklets]], truth: Sequence[Sequence[GroundTruthFrame]]
) -> ModuleCounts:
    """`count_clip` summed over clips, a fresh tracker of `config` per clip."""
    total = ModuleCounts()
    for frames, labelled in zip(clips, truth):
        total = total + count_clip(Tracker(config), frames, labelled)
    return total


@dataclass(frozen=True)
class ClosePairs:
    """Pair-frames of labelled players within the split module's window, by how the tracklets at t show them."""

    pairs: int = 0
    separate: int = 0
    fused: int = 0
    one: int = 0
    none: int = 0

    __add__ = _add_counts


def close_pairs(frames: Sequence[Tracklets], truth: Sequence[GroundTruthFrame]) -> ClosePairs:
    """How the tracklets at t (one clip, frame by frame) show the labelled players within the tracker's split
    window (train.tracking.split.SplitConfig, as the tracker uses it)."""
    config, total = SplitConfig(), ClosePairs()
    for tracklets, labelled in zip(frames, truth):
        boxes, centres = tracklets.boxes[:, -1], labelled.boxes[:, :2]
        labels = box_labels(boxes, labelled)
        gap = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
        first, second = np.nonzero(np.triu((gap >= config.min_pair_gap_m) & (gap <= config.max_pair_gap_m), 1))
        counts = {"pairs": len(first)}
        for a, b in zip(first.tolist(), second.tolist()):
            found = [k for k in (a, b) if np.isin(labelled.ids[k], labels)]
            if len(found) != 1:
                kind = "separate" if found else "none"
            else:
                k = found[0]
                mid = 0.5 * (centres[a] + centres[b])
                on = boxes[labels == labelled.ids[k], :2]
                fused = np.linalg.norm(on - mid, axis=1) < np.linalg.norm(on - centres[k], axis=1)
                kind = "fused" if fused.any() else "one"
            counts[kind] = counts.get(kind, 0) + 1
        total = total + ClosePairs(**counts)
    return total
