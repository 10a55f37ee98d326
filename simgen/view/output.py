"""Frames of a clip to files: one PNG per frame and an MP4, each written atomically.

The MP4 is H.264 (yuv420p, `+faststart`), encoded by the ffmpeg binary that the `imageio-ffmpeg`
package ships (libx264), so that browsers play it in a `<video>` element.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import imageio_ffmpeg
import numpy as np

from simgen.atomic import atomic_path
from simgen.datasets.reader import Dataset
from simgen.errors import UserError
from simgen.view.draw import Canvas, background, canvas_for, render_frame

VIDEO_CODEC = "libx264"
#: x264 settings: constant quality 20 (visually near-lossless for line art), one thread so the same
#: frames give the same bytes, the index up front so that a browser starts playing at once.
VIDEO_OPTIONS = ["-crf", "20", "-preset", "medium", "-threads", "1", "-movflags", "+faststart", "-fflags", "+bitexact"]


@dataclass(frozen=True)
class ClipView:
    """What `write_clip_view` wrote."""

    pngs: tuple[Path, ...]
    video: Path
    frames: int
    size_px: tuple[int, int]  # width, height


@contextlib.contextmanager
def atomic_suffixed(path: Path) -> Iterator[Path]:
    """Like `atomic_path`, but the temporary name keeps the suffix (writers that choose the format by it)."""
    with atomic_path(path) as tmp:
        named = tmp.with_name(tmp.name + path.suffix)
        try:
            yield named
            os.replace(named, tmp)
        finally:
            named.unlink(missing_ok=True)


def write_png(image: np.ndarray, path: Path) -> None:
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise UserError(f"{path}: OpenCV could not encode the image")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.tobytes())


def clip_canvas(dataset: Dataset, px_per_m: float) -> tuple[Canvas, np.ndarray]:
    """The canvas and the background every frame of the dataset is drawn on."""
    sensors = list(dataset.manifest.sensors)
    canvas = canvas_for(sensors, px_per_m)
    return canvas, background(canvas, sensors)


def write_clip_view(
    dataset: Dataset, clip: str, frames: range, out_dir: Path, colouring: str, px_per_m: float
) -> ClipView:
    """OUT/<clip>/frame_NNNNNN.png for each frame and OUT/<clip>.mp4 of them all, at the clip's frame rate."""
    canvas, base = clip_canvas(dataset, px_per_m)
    frame_dir = out_dir / clip
    frame_dir.mkdir(parents=True, exist_ok=True)
    video = out_dir / f"{clip}.mp4"
    fps = dataset.manifest.sensors[0].frame_rate_hz
    pngs = []
    with atomic_suffixed(video) as tmp:
        encoder = imageio_ffmpeg.write_frames(
            str(tmp), (canvas.width, canvas.height), pix_fmt_in="bgr24", fps=fps, codec=VIDEO_CODEC,
            macro_block_size=2, output_params=VIDEO_OPTIONS,
        )
        try:
            encoder.send(None)
            for index in frames:
                image = render_frame(dataset.frame(clip, index), canvas, base, colouring)
                png = frame_dir / f"frame_{index:06d}.png"
                write_png(image, png)
                pngs.append(png)
                encoder.send(np.ascontiguousarray(image))
        except (OSError, RuntimeError) as error:
            raise UserError(f"{video}: ffmpeg ({VIDEO_CODEC}) could not encode the video ({error})") from None
        finally:
            encoder.close()
    return ClipView(tuple(pngs), video, len(pngs), (canvas.width, canvas.height))
