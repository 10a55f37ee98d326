"""The ImageSets of KITTI and OpenPCDet: split by clip, and a dataset of one clip still has a val sample
(OpenPCDet's evaluation indexes the first val info)."""

from __future__ import annotations

import pytest

from simgen.datasets.samples import VAL_FRACTION, sample_name
from tests.support.datasets import make_clip, write_dataset


@pytest.mark.parametrize("format", ["openpcdet", "kitti"])
def test_one_clip_puts_its_last_frames_in_val(tmp_path, format):
    write_dataset(tmp_path, format, [make_clip("clip_0000", 10, points=50)])
    sets = {name: (tmp_path / "ImageSets" / f"{name}.txt").read_text().split() for name in ("train", "val", "trainval")}
    every = [sample_name(0, i) for i in range(10)]
    assert sets["val"] == every[-round(VAL_FRACTION * 10):] and sets["train"] == every[: -len(sets["val"])]
    assert sets["trainval"] == every
    assert "a dataset of one clip" in (tmp_path / "README.md").read_text()


def test_a_one_frame_clip_has_no_val_to_give(tmp_path):
    write_dataset(tmp_path, "openpcdet", [make_clip("clip_0000", 1, points=50)])
    assert (tmp_path / "ImageSets" / "val.txt").read_text() == ""
