"""`track --rerun FILE`: the run's points, labels and tracks as one Rerun recording (.rrd; `rerun FILE.rrd`).

Entities, in the pitch frame (metres, z up), as simgen.view.rerun_view lays out a clip (its static pitch and
sensors under `world`), each clip in its own subtree `world/<clip>/`:

- `points`: the frame's points, coloured by height;
- `labels`: the labelled boxes with their track ids (where the frames have labels);
- `tracks`: the tracks' boxes, one colour per id (simgen.view.trajectories.id_colour, as in the MCAP bags and
  the Fig. 6 pictures), labelled with id and state, dying tracks faint;
- `trajectories`: each live track's last TRAIL_FRAMES centres as a line strip.

Every frame is logged on the `frame` (its index in the clip) and `game_time` timelines, at its label time;
Rerun's wall-clock `log_time` is left out. The file is written under a temporary name and renamed when the
run has succeeded (simgen.view.output.atomic_suffixed).
"""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from simgen.datasets.frame import Frame
from simgen.view.draw import point_colours
from simgen.view.output import atomic_suffixed
from simgen.view.rerun_view import APPLICATION_ID, POINT_RADIUS_M, log_static
from simgen.view.trajectories import id_colour
from train.track.outputs import TRAIL_FRAMES
from train.tracking.types import DYING, STATES, TrackedFrame


def _quaternions(yaw: np.ndarray) -> np.ndarray:
    """(N, 4) x, y, z, w of turns by yaw about z."""
    return np.column_stack([np.zeros((len(yaw), 2)), np.sin(yaw / 2), np.cos(yaw / 2)])


class RerunTracks:
    """The recording, opened on `path` (a temporary name until `close`); `start_clip`, then `add` each final frame."""

    def __init__(self, path: Path, sensors: Sequence, recording_id: str) -> None:
        import rerun as rr

        self.rr = rr
        self.files = contextlib.ExitStack()
        self.temporary = self.files.enter_context(atomic_suffixed(path))
        self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id, send_properties=False)
        rr.set_log_time_enabled(False, recording=self.rec)
        self.rec.save(self.temporary)
        log_static(self.rec, list(sensors))
        self.clip = ""
        self.trails: dict[int, deque] = {}

    def start_clip(self, clip: str) -> None:
        self.clip, self.trails = clip, {}

    def add(self, frame: Frame, tracked: TrackedFrame) -> None:
        rr, rec, root = self.rr, self.rec, f"world/{self.clip}"
        rec.set_time("frame", sequence=frame.index)
        rec.set_time("game_time", duration=frame.label_time_s)
        points = np.asarray(frame.points_m, np.float32)
        colours = np.ascontiguousarray(point_colours(points[:, 2], "height")[:, ::-1])  # BGR -> RGB
        rec.log(f"{root}/points", rr.Points3D(points, colors=colours, radii=POINT_RADIUS_M))
        if frame.track_id is not None:
            boxes = np.asarray(frame.boxes, np.float64).reshape(-1, 7)
            rec.log(f"{root}/labels", rr.Boxes3D(
                centers=boxes[:, :3], half_sizes=boxes[:, 3:6] / 2, quaternions=_quaternions(boxes[:, 6]),
                colors=(255, 255, 255), labels=[str(int(i)) for i in frame.track_id], show_labels=False))
        states = tracked.states if tracked.states is not None else np.zeros(len(tracked.ids), np.int8)
        alpha = np.where(states == DYING, 0.3, 0.9)
        colours = np.array([(*id_colour(i), a) for i, a in zip(tracked.ids.tolist(), alpha.tolist())]).reshape(-1, 4)
        rec.log(f"{root}/tracks", rr.Boxes3D(
            centers=tracked.boxes[:, :3], half_sizes=tracked.boxes[:, 3:6] / 2,
            quaternions=_quaternions(tracked.boxes[:, 6]), colors=(255 * colours).astype(np.uint8),
            labels=[f"{i} {STATES[s]}" for i, s in zip(tracked.ids.tolist(), states.tolist())], show_labels=True))
        for track, box in zip(tracked.ids.tolist(), tracked.boxes.tolist()):
            self.trails.setdefault(track, deque(maxlen=TRAIL_FRAMES)).append((box[0], box[1], 0.05))
        live = tracked.ids.tolist()
        self.trails = {track: self.trails[track] for track in live}  # the dead tracks' trails end
        rec.log(f"{root}/trajectories", rr.LineStrips3D(
            [np.array(self.trails[t]) for t in live],
            colors=(255 * colours[:, :3]).astype(np.uint8) if live else None))

    def close(self) -> None:
        """The recording finished and renamed to its path."""
        self.rec.flush()
        self.rec.disconnect()
        self.files.close()

    def abort(self) -> None:
        """The recording dropped (the run failed): nothing left at its path."""
        self.rec.disconnect()
        self.files.__exit__(RuntimeError, RuntimeError("track failed"), None)
