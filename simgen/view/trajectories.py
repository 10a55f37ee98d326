"""The paper's Fig. 6: a clip's labelled trajectories beside its tracked ones over the pitch, one colour per id.

Tracks come from the `tracks.parquet` table that `simgen-train track` writes (columns clip, frame,
track_id, x, y, ...; one row per track and frame). Left: each labelled humanoid's path (its box centres;
a line breaks where the engine placed it for a restart). Right: each track's path. An identity switch is
marked on both with a red ring: where a labelled humanoid, matched to a track in consecutive frames
(centres within MATCH_M, Hungarian on centre distance), is matched to another track than before.
`write_trajectory_view` writes the picture of the whole window and an H.264 video that draws it frame
by frame (simgen.view.output's encoder).
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.typing import NDArray

from simgen.errors import UserError
from simgen.view.draw import FONT, HEADER_PX, TEXT_COLOUR, Canvas, canvas_for, pitch_lines

if TYPE_CHECKING:
    from simgen.datasets.reader import Dataset

MATCH_M = 1.0  # a labelled and a tracked centre this close may be the same player
SWITCH_COLOUR = (40, 40, 255)  # BGR red
BACKGROUND = (28, 48, 28)
LINE_COLOUR = (110, 130, 110)
GAP_PX = 8


def id_colour(track_id: int) -> tuple[float, float, float]:
    """An RGB colour (0-1) per id, hues the golden angle apart: the same in the pictures and in track's bags."""
    return colorsys.hsv_to_rgb((track_id * 0.618033988749895) % 1.0, 0.85, 1.0)


def _bgr(track_id: int) -> tuple[int, int, int]:
    r, g, b = id_colour(track_id)
    return int(255 * b), int(255 * g), int(255 * r)


@dataclass(frozen=True)
class Paths:
    """Per frame of a window, the ids and (x, y) centres of one side: labels or tracks."""

    ids: list[NDArray[np.int64]]
    xy: list[NDArray[np.float64]]
    breaks: list[NDArray[np.bool_]]  # (n,) a path starts again here (a placement)


def read_tracks(path: Path, clip: str, frames: range) -> Paths:
    """The tracks of `clip` at `frames` from a `tracks.parquet` table."""
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path, columns=["clip", "frame", "track_id", "x", "y"])
    except (OSError, ValueError, KeyError) as error:
        raise UserError(f"{path}: not a tracks table of `simgen-train track` ({error.__class__.__name__})") from None
    table = table.filter(pc.equal(table["clip"], clip))
    if not table.num_rows:
        raise UserError(f"{path}: no tracks of clip {clip}")
    frame = table["frame"].to_numpy()
    ids, xy = table["track_id"].to_numpy(), np.column_stack([table["x"].to_numpy(), table["y"].to_numpy()])
    rows = [frame == f for f in frames]
    return Paths([ids[r] for r in rows], [xy[r].astype(np.float64) for r in rows],
                 [np.zeros(int(r.sum()), bool) for r in rows])


def read_labels(dataset: Dataset, clip: str, frames: range) -> Paths:
    """The labelled humanoids of `clip` at `frames` (their track ids and box centres)."""
    ids, xy, breaks = [], [], []
    for index in frames:
        frame = dataset.frame(clip, index)
        if frame.track_id is None:
            raise UserError(f"{dataset.root}: a {dataset.format} dataset keeps no track ids to draw trajectories of")
        ids.append(frame.track_id.astype(np.int64))
        xy.append(np.asarray(frame.boxes[:, :2], np.float64))
        placed = frame.discontinuity if frame.discontinuity is not None else np.zeros(len(frame.boxes), bool)
        breaks.append(np.asarray(placed, bool))
    return Paths(ids, xy, breaks)


def id_switches(labels: Paths, tracks: Paths) -> list[tuple[int, float, float]]:
    """(frame position in the window, x, y) of every identity switch (see the module's docstring)."""
    from scipy.optimize import linear_sum_assignment

    last: dict[int, int] = {}
    switches = []
    for k, (gt_ids, gt_xy, tr_ids, tr_xy) in enumerate(zip(labels.ids, labels.xy, tracks.ids, tracks.xy)):
        gap = np.linalg.norm(gt_xy[:, None] - tr_xy[None], axis=-1)
        rows, cols = linear_sum_assignment(np.where(gap <= MATCH_M, gap, 1e6)) if gap.size else ([], [])
        for row, col in zip(rows, cols):
            if gap[row, col] > MATCH_M:
                continue
            gt, track = int(gt_ids[row]), int(tr_ids[col])
            if gt in last and last[gt] != track:
                switches.append((k, float(gt_xy[row, 0]), float(gt_xy[row, 1])))
            last[gt] = track
    return switches


def _panel(canvas: Canvas, paths: Paths, upto: int, title: str, switches: list[tuple[int, float, float]]
           ) -> NDArray[np.uint8]:
    """One side's picture: the pitch, every id's path over the window's first `upto` + 1 frames, the switches."""
    image = np.full((HEADER_PX + canvas.bev_height, canvas.width, 3), BACKGROUND, np.uint8)
    image[:HEADER_PX] = 0
    cv2.polylines(image, pitch_lines(canvas), False, LINE_COLOUR, 1, cv2.LINE_AA)
    trail: dict[int, list[NDArray[np.int32]]] = {}
    segments: list[tuple[int, NDArray[np.int32]]] = []
    for ids, xy, breaks in zip(paths.ids[: upto + 1], paths.xy[: upto + 1], paths.breaks[: upto + 1]):
        pixels = canvas.bev(xy[:, 0], xy[:, 1]).reshape(-1, 2)
        seen = set(ids.tolist())
        for gone in [i for i in trail if i not in seen]:
            segments.append((gone, np.array(trail.pop(gone))))
        for track, at, restart in zip(ids.tolist(), pixels, breaks.tolist()):
            if restart and track in trail:
                segments.append((track, np.array(trail.pop(track))))
            trail.setdefault(track, []).append(at)
    segments += [(track, np.array(points)) for track, points in trail.items()]
    for track, points in segments:
        cv2.polylines(image, [points.astype(np.int32)], False, _bgr(track), 2, cv2.LINE_AA)
    for track, points in trail.items():
        cv2.circle(image, tuple(int(v) for v in points[-1]), 4, _bgr(track), -1, cv2.LINE_AA)
    for k, x, y in switches:
        if k <= upto:
            cv2.circle(image, tuple(int(v) for v in canvas.bev(x, y)), 9, SWITCH_COLOUR, 2, cv2.LINE_AA)
    shown = sum(1 for k, _, _ in switches if k <= upto)
    cv2.putText(image, f"{title}: {len(trail)} ids now, {shown} ID switches (red rings)", (6, 19), FONT, 0.5,
                TEXT_COLOUR, 1, cv2.LINE_AA)
    return image


def side_by_side(canvas: Canvas, labels: Paths, tracks: Paths, upto: int, switches) -> NDArray[np.uint8]:
    """The labelled paths (left) and the tracked ones (right) up to frame `upto` of the window."""
    left = _panel(canvas, labels, upto, "labelled", switches)
    right = _panel(canvas, tracks, upto, "tracked", switches)
    return np.concatenate([left, np.zeros((left.shape[0], GAP_PX, 3), np.uint8), right], axis=1)


def write_trajectory_view(dataset: Dataset, clip: str, frames: range, tracks_table: Path, out: Path,
                          px_per_m: float) -> tuple[Path, Path, int]:
    """OUT/<clip>_tracks.png (the whole window) and OUT/<clip>_tracks.mp4 (drawn frame by frame); returns them
    and the number of identity switches."""
    import imageio_ffmpeg

    from simgen.view.output import VIDEO_CODEC, VIDEO_OPTIONS, atomic_suffixed, write_png

    sensors = list(dataset.manifest.sensors)
    canvas = canvas_for(sensors, px_per_m)
    tracks = read_tracks(tracks_table, clip, frames)
    labels = read_labels(dataset, clip, frames)
    switches = id_switches(labels, tracks)
    png, video = out / f"{clip}_tracks.png", out / f"{clip}_tracks.mp4"
    last = side_by_side(canvas, labels, tracks, len(frames) - 1, switches)
    write_png(last, png)
    height, width = last.shape[:2]
    with atomic_suffixed(video) as tmp:
        encoder = imageio_ffmpeg.write_frames(str(tmp), (width, height), pix_fmt_in="bgr24",
                                              fps=sensors[0].frame_rate_hz, codec=VIDEO_CODEC, macro_block_size=2,
                                              output_params=VIDEO_OPTIONS)
        try:
            encoder.send(None)
            for upto in range(len(frames)):
                encoder.send(np.ascontiguousarray(side_by_side(canvas, labels, tracks, upto, switches)))
        except (OSError, RuntimeError) as error:
            raise UserError(f"{video}: ffmpeg ({VIDEO_CODEC}) could not encode the video ({error})") from None
        finally:
            encoder.close()
    return png, video, len(switches)
