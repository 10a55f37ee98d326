"""The `kitti` format (KITTI object detection: a file per frame, split by ImageSets; optional placeholder
images): its writer, reader and plug-in, and the files and reader that `kitti_tracking` (kitti_tracking.py)
shares with it.

kitti:          training/velodyne/NNNNNN.bin, training/label_2/NNNNNN.txt, training/calib/NNNNNN.txt,
                ImageSets/{train,val,trainval}.txt; NNNNNN the global sample number (simgen.datasets.samples);
                optionally training/image_2/NNNNNN.png, blank placeholders of the virtual camera's size
                (OpenPCDet's KITTI info generation reads every image's shape)
kitti_tracking: training/velodyne/SSSS/NNNNNN.bin, training/label_02/SSSS.txt (frame and track id
                first), training/calib/SSSS.txt, training/placements/SSSS.txt (`frame track_id` of each
                box whose humanoid the engine placed for a restart: its `discontinuity`; KITTI's
                tracking tools ignore the folder); SSSS the clip index, NNNNNN the frame index

.bin: float32 x, y, z, intensity / 255 per point, pitch frame. Labels: `Pedestrian` (players) or
`Official` (referee, linesmen), in the virtual camera of `kitti_camera`; truncation 0; occlusion 0,
or 3 (unknown) for a box with no point on it. The ball is not labelled.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from simgen.atomic import atomic_path
from simgen.datasets import kitti_camera as camera
from simgen.datasets.formats import MAX_FRAMES_PER_CLIP
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.frame import Frame, class_names
from simgen.datasets.kitti_camera import IMAGE_SIZE_PX, calib_lines, kitti_boxes, pitch_boxes
from simgen.datasets.limits import check_label_lines
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import ClipRecord, FileRecord, record_file, write_bytes, write_text
from simgen.datasets.samples import (
    IMAGE_SETS,
    INTENSITY_SCALE,
    VAL_FRACTION,
    float32_text,
    float64_text,
    from_xyzi,
    sample_name,
    to_xyzi,
    write_image_sets,
)
from simgen.datasets.verify import DatasetFiles
from simgen.errors import UserError
from simgen.vocab import CLASS_NAMES

if TYPE_CHECKING:
    from simgen.labels.labelled_frame import LabelledFrame


UNKNOWN_OCCLUSION = 3
TRACK_ID_SPAN = 1 << 31  # track ids are int32: frame * span + track id is unique
OPEN_CLIPS = 4  # tracking label files the reader keeps parsed


def velodyne_path(tracking: bool, clip_index: int, index: int) -> str:
    if tracking:
        return f"training/velodyne/{clip_index:04d}/{index:06d}.bin"
    return f"training/velodyne/{sample_name(clip_index, index)}.bin"


def label_path(tracking: bool, clip_index: int, index: int = 0) -> str:
    return (
        f"training/label_02/{clip_index:04d}.txt"
        if tracking
        else f"training/label_2/{sample_name(clip_index, index)}.txt"
    )


def calib_path(tracking: bool, clip_index: int, index: int = 0) -> str:
    return (
        f"training/calib/{clip_index:04d}.txt" if tracking else f"training/calib/{sample_name(clip_index, index)}.txt"
    )


def placements_path(clip_index: int) -> str:
    """kitti_tracking's list of the boxes with a discontinuity (`frame track_id` lines)."""
    return f"training/placements/{clip_index:04d}.txt"


def image_path(clip_index: int, index: int) -> str:
    return f"training/image_2/{sample_name(clip_index, index)}.png"


@functools.cache
def placeholder_png() -> bytes:
    """A blank 1-bit PNG of the virtual camera's nominal size (a few kB; decoded, one byte per pixel)."""
    import cv2  # only for --kitti-images; readers of simgen.datasets need no OpenCV

    ok, data = cv2.imencode(".png", np.zeros(IMAGE_SIZE_PX[::-1], np.uint8), [cv2.IMWRITE_PNG_BILEVEL, 1])
    if not ok:
        raise UserError("OpenCV could not encode the placeholder image")
    return data.tobytes()


def write_placeholder_images(root: Path, clips: Sequence[tuple[int, int]]) -> list[FileRecord]:
    """training/image_2/NNNNNN.png for every (clip index, frames) of `clips`; rows = 1 (one image each)."""
    return [
        write_bytes(root, image_path(clip_index, i), placeholder_png(), 1)
        for clip_index, frames in clips
        for i in range(frames)
    ]


def box_fields(boxes: NDArray) -> list[str]:
    """`alpha x1 y1 x2 y2 h w l x y z ry` of pitch-frame boxes (H, 7), as the label lines write them."""
    fields = kitti_boxes(boxes)
    out = []
    for i in range(len(fields["ry"])):
        bbox = " ".join(f"{v:.2f}" for v in fields["bbox"][i])
        dims = " ".join(float32_text(v) for v in fields["dims"][i])
        location = " ".join(float64_text(v) for v in fields["location"][i])
        out.append(f"{fields['alpha'][i]:.2f} {bbox} {dims} {location} {float64_text(fields['ry'][i])}")
    return out


def label_lines(frame: LabelledFrame) -> list[str]:
    """Object label lines, `type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry` (tracking puts frame and
    track id first)."""
    labels = frame.labels
    occluded = np.where(labels.num_points > 0, 0, UNKNOWN_OCCLUSION)
    return [
        f"{name} 0 {occlusion} {fields}"
        for name, occlusion, fields in zip(class_names(labels.team), occluded.tolist(), box_fields(labels.boxes))
    ]


class KittiClipStream:
    """One clip's KITTI files written as its frames come: per frame its .bin (and, for `kitti`, its
    label and calib); `kitti_tracking`'s one label file per clip grows under a temporary name
    until `close` renames it."""

    def __init__(self, root: Path, clip_index: int, tracking: bool):
        self.root, self.clip_index, self.tracking = Path(root), clip_index, tracking
        self.records: list[FileRecord] = []
        self._files = contextlib.ExitStack()
        self._lines = 0
        self._placements: list[str] = []  # kitti_tracking: `frame track_id` of boxes with a discontinuity
        if tracking:
            path = self.root / label_path(True, clip_index)
            path.parent.mkdir(parents=True, exist_ok=True)
            self._labels = self._files.enter_context(
                self._files.enter_context(atomic_path(path)).open("w", encoding="utf-8", newline="\n")
            )

    def add(self, frame: LabelledFrame) -> None:
        xyzi = to_xyzi(frame.scan.points_m, frame.scan.intensity)
        self.records.append(
            write_bytes(
                self.root, velodyne_path(self.tracking, self.clip_index, frame.index), xyzi.tobytes(), len(xyzi)
            )
        )
        if self.tracking:
            lines = [f"{frame.index} {track} {line}" for track, line in zip(frame.labels.track_id, label_lines(frame))]
            self._labels.write("".join(f"{line}\n" for line in lines))
            self._lines += len(lines)
            self._placements += [
                f"{frame.index} {track}" for track in frame.labels.track_id[frame.labels.discontinuity]
            ]
        else:
            self.records.append(
                write_text(self.root, label_path(False, self.clip_index, frame.index), label_lines(frame))
            )
            self.records.append(
                write_text(self.root, calib_path(False, self.clip_index, frame.index), calib_lines(False))
            )

    def close(self) -> list[FileRecord]:
        self._files.close()
        if self.tracking:
            self.records.append(record_file(self.root, label_path(True, self.clip_index), self._lines))
            self.records.append(write_text(self.root, calib_path(True, self.clip_index), calib_lines(True)))
            self.records.append(write_text(self.root, placements_path(self.clip_index), self._placements))
        return self.records

    def abort(self) -> None:
        self._files.__exit__(RuntimeError, RuntimeError("aborted"), None)


def parse_labels(text: str, path: Path, tracking: bool) -> dict[str, NDArray]:
    """Label lines -> frame, track_id (tracking), class_name and pitch-frame boxes."""
    leading = 2 if tracking else 0
    rows = [line.split() for line in text.splitlines() if line.strip()]
    for number, row in enumerate(rows, 1):
        if len(row) != leading + 15 or row[leading] not in CLASS_NAMES:
            raise UserError(f"{path}: line {number} is not a simgen KITTI label ({' '.join(row[: leading + 1])} ...)")
    try:
        values = np.array([row[leading + 8 : leading + 15] for row in rows], np.float64).reshape(-1, 7)
        ids = np.array([row[:2] for row in rows] if tracking else np.zeros((len(rows), 2)), np.int64).reshape(-1, 2)
    except ValueError:
        raise UserError(f"{path}: a label has a field that is not a number") from None
    return {
        "frame": ids[:, 0],
        "track_id": ids[:, 1].astype(np.int32) if tracking else None,
        "class_name": np.array([row[leading] for row in rows], np.str_),
        "boxes": pitch_boxes(values[:, :3], values[:, 3:6], values[:, 6]),
    }


def read_velodyne(data: bytes, path: Path, rows: int) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    if len(data) % 16 or len(data) // 16 != rows:
        raise UserError(f"{path}: {len(data)} bytes are not the {rows} points x 4 float32 the manifest lists")
    return from_xyzi(np.frombuffer(data, np.float32).reshape(-1, 4))


class KittiReader:
    """Frames of a `kitti` or `kitti_tracking` dataset."""

    def __init__(self, files: DatasetFiles, clip_indices: dict[str, int], tracking: bool, frames: dict[int, int]):
        self.files = files
        self.clip_indices = clip_indices
        self.tracking = tracking
        self.frames = frames  # per clip index
        self._labels = functools.lru_cache(maxsize=OPEN_CLIPS)(self._read_labels)

    def _read_labels(self, clip_index: int, index: int) -> dict[str, NDArray]:
        calib = calib_path(self.tracking, clip_index, index)
        if self.files.read(calib).decode(errors="replace").splitlines() != calib_lines(self.tracking):
            raise UserError(f"{self.files.root / calib}: not simgen's virtual camera (see the dataset README)")
        relative = label_path(self.tracking, clip_index, index)
        text = self.files.read(relative).decode(errors="replace")
        check_label_lines(self.files.root / relative, text, self.frames[clip_index] if self.tracking else 1)
        labels = parse_labels(text, self.files.root / relative, self.tracking)
        if self.tracking:
            labels["discontinuity"] = np.isin(
                labels["frame"] * TRACK_ID_SPAN + labels["track_id"], self._placements(clip_index)
            )
        return labels

    def _placements(self, clip_index: int) -> NDArray[np.int64]:
        """`frame * TRACK_ID_SPAN + track id` of each box that training/placements/SSSS.txt lists."""
        relative = placements_path(clip_index)
        try:
            pairs = np.array(
                [line.split() for line in self.files.read(relative).decode().splitlines() if line.strip()], np.int64
            )
        except ValueError:
            raise UserError(f"{self.files.root / relative}: not lines of `frame track_id`") from None
        if pairs.size and (
            pairs.ndim != 2 or pairs.shape[1] != 2 or (pairs[:, 1] < 0).any() or (pairs[:, 1] >= TRACK_ID_SPAN).any()
        ):
            raise UserError(f"{self.files.root / relative}: not lines of `frame track_id`")
        return pairs.reshape(-1, 2) @ np.array([TRACK_ID_SPAN, 1])

    def frame(self, clip: str, index: int) -> Frame:
        clip_index = self.clip_indices[clip]
        velodyne = velodyne_path(self.tracking, clip_index, index)
        points, intensity = read_velodyne(
            self.files.read(velodyne), self.files.root / velodyne, self.files.rows(velodyne)
        )
        labels = self._labels(clip_index, 0 if self.tracking else index)
        mine = labels["frame"] == index if self.tracking else slice(None)
        return Frame(
            clip=clip,
            index=index,
            points_m=points,
            intensity=intensity,
            boxes=labels["boxes"][mine],
            class_name=labels["class_name"][mine],
            track_id=labels["track_id"][mine] if self.tracking else None,
            discontinuity=labels["discontinuity"][mine] if self.tracking else None,
        )


def _with_images(scenario: Mapping) -> bool:
    """Whether the scenario asked for placeholder images (`dataset.kitti_images`)."""
    return bool(scenario.get("dataset", {}).get("kitti_images"))


class Kitti(DatasetFormat):
    name = "kitti"
    carries = Carries(track_ids=False, point_fields=False, point_counts=False)
    frame_files = True
    tracking = False  # KITTI tracking's layout (kitti_tracking.py)

    def stream(self, root, clip, clip_index, sensors):
        return KittiClipStream(root, clip_index, tracking=self.tracking)

    def reader(self, files, manifest):
        clips = manifest.clips
        return KittiReader(files, {c.clip: c.clip_index for c in clips}, self.tracking,
                           {c.clip_index: c.frames for c in clips})

    def clip_files(self, entry: ClipEntry) -> set[str]:
        paths = (velodyne_path, label_path, calib_path)
        return {f(self.tracking, entry.clip_index, i) for i in range(entry.frames) for f in paths}

    def dataset_files(self, manifest: Manifest) -> set[str]:
        images = {image_path(c.clip_index, i) for c in manifest.clips for i in range(c.frames)}
        return set(IMAGE_SETS) | (images if _with_images(manifest.scenario) else set())

    def finish(self, root: Path, clips: Sequence[ClipRecord], sensors, scenario: Mapping) -> list[FileRecord]:
        files = write_image_sets(root, clips)
        if _with_images(scenario):
            files += write_placeholder_images(root, [(c.clip_index, c.frames) for c in clips])
        return files

    def card_layout(self, manifest: Manifest) -> list[str]:
        return self._files(_with_images(manifest.scenario)) + _common_layout()

    def _files(self, images: bool) -> list[str]:
        files = [
            f"- `training/velodyne/NNNNNN.bin`: NNNNNN = clip index x {MAX_FRAMES_PER_CLIP} + frame index",
            "- `training/label_2/NNNNNN.txt`: `type truncated occluded alpha x1 y1 x2 y2 h w l x y z ry`",
            "- `training/calib/NNNNNN.txt`: KITTI object calib "
            "(`P0:`-`P3:`, `R0_rect:`, `Tr_velo_to_cam:`, `Tr_imu_to_velo:`)",
            "- `ImageSets/train.txt`, `val.txt`, `trainval.txt`: sample numbers, split by clip (a dataset of one clip:",
            f"  its last {VAL_FRACTION:.0%} of frames are `val`, so that OpenPCDet's evaluation has a sample)",
        ]
        if images:
            files.append(
                "- `training/image_2/NNNNNN.png`: blank placeholders of the virtual camera's nominal size (1-bit PNG),"
                " for tools that open every image (OpenPCDet's KITTI info generation)"
            )
        return files

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        return lambda k, i: (str(root / label_path(False, entry.clip_index, k)), i + 1)  # line number, from 1


def _common_layout() -> list[str]:
    """The card's lines on the .bin files and the virtual camera, for both KITTI layouts."""
    min_height_m = camera.MIN_BOX_PX * (camera.CAMERA_DISTANCE_M + camera.MAX_X_M) / camera.FOCAL_PX
    return [
        "",
        f"`.bin`: float32 x, y, z (metres, **pitch frame**, not the sensor's), intensity / {INTENSITY_SCALE:g} "
        "in [0, 1].",
        "The \"velodyne\" frame of these files is the pitch frame: KITTI tools that assume a sensor at the origin",
        "looking along +x (range crops, field-of-view filters) need the pitch's range instead.",
        "",
        "Labels are in a **virtual camera** (a stationary LiDAR over a pitch has none), stated exactly in `calib/`:",
        f"a pinhole at pitch (-{camera.CAMERA_DISTANCE_M:g}, 0, 0) m looking along +x with KITTI's camera axes,",
        f"`x_cam = -y`, `y_cam = -z`, `z_cam = x + {camera.CAMERA_DISTANCE_M:g}` "
        "(`Tr_velo_to_cam`; `R0_rect` = identity;",
        f"`Tr_imu_to_velo` = identity, there is no IMU), focal length {camera.FOCAL_PX:g} px, principal point",
        f"{camera.PRINCIPAL_PX} px, nominal image {camera.IMAGE_SIZE_PX[0]} x {camera.IMAGE_SIZE_PX[1]} px "
        "(image files only as placeholders).",
        "`location` is the box's bottom centre in that camera, `h w l` its height, width (across the heading) and",
        "length (along it), `ry = -yaw - pi/2`; `alpha = ry - atan2(x_cam, z_cam)`. The 2D box is the projection of",
        "the 8 corners with P2 (not clipped): a box",
        f"{min_height_m:.2f} m tall or more is at least {camera.MIN_BOX_PX:g} px tall "
        f"anywhere up to x = {camera.MAX_X_M:g} m,",
        "so KITTI's evaluators (which drop boxes under 25-40 px) keep every humanoid.",
        "`truncated` is 0; `occluded` is 0, or 3 (unknown) for a humanoid with no point on it in that frame.",
    ]


FORMAT = Kitti()
