"""`simgen coverage`: standing players batched without changing a point, the report and its verdict, the greedy
pick, bad input refused in one line, and the match's points by distance agreeing with a generated dataset."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import simgen.coverage.grid as grid_module
from simgen.cli import main
from simgen.coverage.candidates import greedy_pick
from simgen.coverage.grid import grid_coverage
from simgen.coverage.summary import by_distance
from simgen.datasets import open_dataset
from simgen.scenario import load_scenario, parse_scenario
from tests.support import ROOT
from tests.support.hostile import assert_one_line_refusal, run_main

EXACT = {"enabled": False}  # no noise, no dropout: a player's points depend only on the rays that reach it
TOUCHLINE_MID100 = {"name": "mid100", "preset": "mid100-rose", "pose": {"x": 0.0, "y": -35.0, "z": 4.0}}
GOAL_HAP = {"name": "hap", "preset": "hap-rotors", "pose": {"x": -58.0, "y": 0.0, "z": 8.0, "pitch": -5.0, "yaw": 0.0}}


def test_batched_players_get_the_points_they_get_alone(monkeypatch):
    scenario = parse_scenario({"name": "two", "sensors": [TOUCHLINE_MID100, GOAL_HAP], "noise": EXACT})
    monkeypatch.setattr(grid_module, "PATTERN_FRAMES", 1)  # every frame the same rays
    batched = grid_coverage(scenario, 8.0, np.array([0.0, 90.0]))
    monkeypatch.setattr(grid_module, "BODY_RADIUS_M", 500.0)  # every cell a batch of its own
    alone = grid_coverage(scenario, 8.0, np.array([0.0, 90.0]))
    assert batched.frames < alone.frames / 3  # the batching renders several players a frame
    assert batched.points.sum() > 1000
    np.testing.assert_array_equal(batched.points, alone.points)


def test_a_far_player_gets_fewer_points_than_a_near_one():
    scenario = parse_scenario({"name": "one", "sensors": [TOUCHLINE_MID100], "noise": EXACT})
    coverage = grid_coverage(scenario, 4.0, np.array([0.0, 90.0, 180.0, 270.0]))
    centres = coverage.grid.centres_m
    ahead = np.abs(centres[:, 0]) < 2.5  # on the sensor's boresight
    near = coverage.rig_mean[ahead & (centres[:, 1] > -25) & (centres[:, 1] < -10)]  # 10-25 m away
    far = coverage.rig_mean[ahead & (centres[:, 1] > 20)]
    assert near.min() > 3 * far.max()
    assert coverage.points.shape == (len(centres), 4, 1)


def test_greedy_pick_adds_what_covers_most():
    means = np.array([[6.0, 6.0, 0.0, 0.0], [0.0, 0.0, 6.0, 0.0], [3.0, 3.0, 3.0, 3.0], [0.0, 0.0, 0.0, 6.0]])
    assert greedy_pick(means, np.ones(4, bool), 5.0, 1) == [0]  # 2 cells of 4; the tie with none on soft coverage
    assert greedy_pick(means, np.ones(4, bool), 5.0, 3) == [0, 1, 3]
    assert greedy_pick(means, np.array([False, False, True, True]), 5.0, 1) == [1]


def _rows(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_report_csv_and_verdict(tmp_path):
    out = tmp_path / "cov"
    arguments = ["coverage", ROOT / "scenarios/paper_x1.yaml", ROOT / "scenarios/whole_hap_goals.yaml", "-o", out,
                 "--step", "6", "--headings", "2", "--match-clips", "0"]
    code, stdout, _ = run_main(main, *arguments)
    assert code == 1  # a standing player gets 5 points on only part of the pitch
    assert stdout.splitlines()[-1].startswith("FAIL: 0 passed, 2 failed")
    html = (out / "index.html").read_text()
    assert html.count("<img src=\"data:image/png;base64,") >= 4  # side by side, each rig, the HAP's two sensors
    rows = _rows(out / "whole_hap_goals.csv")
    assert len(rows) == 17 * 11 and set(rows[0]) >= {"x_m", "y_m", "rig_mean", "hap_west_mean", "hap_east_mean"}
    rig, west, east = (np.array([float(r[k]) for r in rows]) for k in ("rig_mean", "hap_west_mean", "hap_east_mean"))
    np.testing.assert_allclose(rig, west + east, atol=2e-3)
    code, stdout, _ = run_main(main, *arguments, "--min-points", "5", "--min-share", "10", "--area", "paper")
    assert code == 0 and stdout.splitlines()[-1].startswith("PASS: 2 passed")


def test_candidates_pick_beats_the_paper_rig(tmp_path):
    out = tmp_path / "pick"
    code, stdout, _ = run_main(
        main, "coverage", ROOT / "scenarios/paper_x1.yaml", "--candidates",
        ROOT / "scenarios/candidates/mid100_masts.yaml", "--sensors", "2", "--step", "10", "--headings", "1",
        "--match-clips", "0", "-o", out,
    )
    assert code == 1
    share = {line.split()[1].rstrip(":"): float(line.split(": ")[2].split(" %")[0]) for line in stdout.splitlines()
             if line.startswith(("pass  ", "FAIL  "))}
    assert share["paper_x1_pick2"] > share["paper_x1"] + 20
    picked = load_scenario(out / "paper_x1_pick2.yaml")  # what `simgen validate` reads
    assert len(picked.sensors) == 2 and {s.preset for s in picked.sensors} == {"mid100-rose"}
    assert picked.scan == load_scenario(ROOT / "scenarios/paper_x1.yaml").scan


def _write(path, document) -> str:
    path.write_text(yaml.safe_dump(document))
    return str(path)


def test_bad_input_is_one_line_and_writes_nothing(tmp_path):
    paper = ROOT / "scenarios/paper_x1.yaml"
    masts = [{"name": f"m{i}", "x": 0.0, "y": -36.0, "z": np.linspace(4, 10, 100).tolist(),
              "pitch": np.linspace(-20, -1, 100).tolist(), "yaw": 90.0} for i in range(100)]
    million = _write(tmp_path / "million.yaml", {"preset": "mid100-rose", "masts": masts})
    two = _write(tmp_path / "two.yaml", {"preset": "mid100-rose", "masts": [
        {"name": "a", "x": 0.0, "y": -36.0, "z": [6.0, 8.0], "pitch": -8.0, "yaw": 90.0}]})
    no_sensor = _write(tmp_path / "none.yaml", {"name": "none", "sensors": []})
    cases = {
        "step 0": [paper, "--step", "0"],
        "step 1e-6": [paper, "--step", "1e-6"],
        "10^6 candidates": [paper, "--candidates", million, "--sensors", "2"],
        "K > candidates": [paper, "--candidates", two, "--sensors", "3"],
        "no sensor": [no_sensor],
        "headings 0": [paper, "--headings", "0"],
        "0.25 m in 16 headings": [paper, "--step", "0.25", "--headings", "16"],
    }
    for what, arguments in cases.items():
        out = tmp_path / "out"
        assert_one_line_refusal(*run_main(main, "coverage", *arguments, "-o", out, "--match-clips", "0"), what)
        assert not out.exists(), what
    whole_match = [ROOT / "scenarios/full_match.yaml", "--match-clips", "1"]  # 54,000 frames of match in memory
    assert_one_line_refusal(*run_main(main, "coverage", *whole_match, "-o", tmp_path / "out"), "a whole match")
    assert not (tmp_path / "out").exists()


@pytest.mark.engine
def test_match_points_by_distance_agree_with_a_generated_dataset(tmp_path):
    document = yaml.safe_load((ROOT / "scenarios/paper_x1.yaml").read_text())
    document["motion"]["frames"] = 101  # 1 s at 100 Hz: 11 frames at 11 Hz
    document["scan"]["frames"] = 11
    document["dataset"]["clips"] = 1
    scenario = _write(tmp_path / "paper_x1.yaml", document)
    assert run_main(main, "generate", scenario, "-o", tmp_path / "dataset")[0] == 0
    out = tmp_path / "cov"
    code, _, _ = run_main(main, "coverage", scenario, "-o", out, "--step", "10", "--headings", "1")
    assert code == 1
    rows = _rows(out / "paper_x1_match.csv")
    coverage = by_distance(np.array([float(r["distance_m"]) for r in rows]),
                           np.array([int(r["points"]) for r in rows]), 130.0)

    sensor = np.array([0.0, -35.0])
    distance, points = [], []
    for frame in open_dataset(tmp_path / "dataset"):
        players = frame.class_name == "Pedestrian"
        distance.append(np.hypot(*(frame.boxes[players, :2] - sensor).T))
        points.append(frame.num_points[players])
    dataset = by_distance(np.concatenate(distance), np.concatenate(points), 130.0)
    assert coverage.count.sum() == dataset.count.sum() == 11 * 22
    seen = dataset.count > 0
    np.testing.assert_array_equal(coverage.count > 0, seen)
    gap = np.abs(coverage.median[seen] - dataset.median[seen])
    assert (gap <= np.maximum(1.0, 0.2 * dataset.median[seen])).all(), (coverage.median, dataset.median)


def test_whole_pitch_detector_configs_cover_the_pitch():
    from train.config import load_config

    for size in ("", "paper/"):
        for model in ("single", "early", "late"):
            config = load_config(ROOT / f"train/configs/{size}whole_pitch/{model}.yaml")
            paper = load_config(ROOT / f"train/configs/{size}{model}.yaml")
            x0, y0, _, x1, y1, _ = config.data.point_range_m
            assert x0 < -52.5 - 3 and x1 > 52.5 + 3 and y0 < -34 - 3 and y1 > 34 + 3
            assert config.model == paper.model and config.train == paper.train
