"""`simgen view`'s MP4: H.264 that OpenCV reads back and headless Chromium plays to the end."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from simgen.cli import main
from tests.support.chromium import evaluate, serve
from tests.support.datasets import make_clip, write_dataset

FRAMES = 12
FPS = 10.0  # tests.support.datasets' sensor

PAGE = """<!DOCTYPE html><html><body><video id="v" src="clip_0000.mp4" muted playsinline></video></body></html>"""

#: Resolves when the video has ended (or failed): its duration, size and the frames the page saw.
PLAY = """new Promise(function (resolve) {
  var video = document.getElementById("v"), presented = 0, last = -1;
  function count(now, meta) {
    if (meta.mediaTime !== last) { presented++; last = meta.mediaTime; }
    video.requestVideoFrameCallback(count);
  }
  video.requestVideoFrameCallback(count);
  video.addEventListener("error", function () { resolve(JSON.stringify({error: video.error.message})); });
  video.addEventListener("ended", function () {
    var quality = video.getVideoPlaybackQuality();
    resolve(JSON.stringify({duration: video.duration, width: video.videoWidth, height: video.videoHeight,
                            presented: presented, decoded: quality.totalVideoFrames}));
  });
  video.play().catch(function (e) { resolve(JSON.stringify({error: String(e)})); });
})"""


@pytest.fixture(scope="module")
def view(tmp_path_factory):
    root = tmp_path_factory.mktemp("view")
    write_dataset(root / "dataset", "parquet", [make_clip("clip_0000", FRAMES)])
    assert main(["view", str(root / "dataset"), "-o", str(root / "out"), "--frames", f"0:{FRAMES}"]) == 0
    return root / "out"


def test_the_mp4_is_h264_and_holds_the_pngs(view):
    video = cv2.VideoCapture(str(view / "clip_0000.mp4"))
    fourcc = int(video.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode().lower()
    assert fourcc in ("avc1", "h264")
    assert video.get(cv2.CAP_PROP_FPS) == FPS
    frames = []
    while (read := video.read())[0]:
        frames.append(read[1])
    assert len(frames) == FRAMES
    first = cv2.imread(str(view / "clip_0000" / "frame_000000.png"))
    assert frames[0].shape == first.shape
    assert np.abs(frames[0].astype(int) - first).mean() < 4  # the same picture through H.264 at constant quality 20


def test_the_same_frames_give_the_same_bytes(view, tmp_path):
    dataset = view.parent / "dataset"
    assert main(["view", str(dataset), "-o", str(tmp_path), "--frames", f"0:{FRAMES}"]) == 0
    assert (tmp_path / "clip_0000.mp4").read_bytes() == (view / "clip_0000.mp4").read_bytes()


def test_chromium_plays_the_mp4_to_the_end(view):
    (view / "index.html").write_text(PAGE)
    with serve(view) as base:
        played = json.loads(evaluate(f"{base}/index.html", PLAY))
    height, width = cv2.imread(str(view / "clip_0000" / "frame_000000.png")).shape[:2]
    assert "error" not in played, played
    assert played["duration"] == pytest.approx(FRAMES / FPS, abs=0.5 / FPS)
    assert (played["width"], played["height"]) == (width, height)
    assert played["decoded"] == FRAMES and 0 < played["presented"] <= FRAMES
