"""Which checkpoints `simgen-train study` reuses: same dataset path and the same scenario, read with today's schema."""

from __future__ import annotations

from simgen.scenario import load_scenario
from tests.support import ROOT
from train.study.run import StudyDataset, _same_data

PAPER_X1 = ROOT / "scenarios" / "paper_x1.yaml"


def _dataset(path) -> StudyDataset:
    return StudyDataset(path, load_scenario(PAPER_X1), False, 0.0, ("clip_0003",), 205)


def test_a_marker_written_before_a_field_was_added_still_matches(tmp_path):
    dataset = _dataset(tmp_path)
    dump = dataset.scenario.model_dump(mode="json")
    del dump["dataset"]["kitti_images"]  # a field newer than the marker, at its default
    assert _same_data({"dataset": str(tmp_path.resolve()), "scenario": dump}, dataset)


def test_another_scenario_path_or_an_unreadable_marker_does_not_match(tmp_path):
    dataset = _dataset(tmp_path)
    dump = dataset.scenario.model_dump(mode="json")
    assert not _same_data({"dataset": str(tmp_path / "other"), "scenario": dump}, dataset)
    assert not _same_data({"dataset": str(tmp_path.resolve()), "scenario": {**dump, "seed": dump["seed"] + 1}}, dataset)
    assert not _same_data({"dataset": str(tmp_path.resolve()), "scenario": {**dump, "nonsense": 1}}, dataset)
    assert not _same_data({"dataset": str(tmp_path.resolve())}, dataset)
