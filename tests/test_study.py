"""`simgen-train study` end to end on a tiny generated dataset, its reuse of data and models, and its one-line
errors."""

from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest
import torch
import yaml

import simgen.datasets
from tests.support import ROOT
from tests.support.detector import SMOKE, tiny_config
from tests.support.hostile import assert_one_line_refusal, run_main
from tests.support.trackers import FULL_TRACKER
from train.checkpoint import load_checkpoint
from train.cli import main
from train.fit import fit
from train.study.run import TRACKER_CONFIGS
from train.tracking.config import load_tracker_configs

pytestmark = pytest.mark.engine
NAME = "study_tiny"
PAPER_X2 = ROOT / "scenarios" / "paper_x2.yaml"
METHODS = ("Single Frame (x1)", "Early Fusion (x1)", "Late Fusion (x1)")


def run_study(*args: object) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of `simgen-train study ARGS`, run in this process (usage errors included)."""
    return run_main(main, "study", *args)


def write_scenario(path, **changes) -> None:
    """The smoke scenario cut to 2 clips of 12 frames (the split puts the last one in val)."""
    data = yaml.safe_load(SMOKE.read_text())
    data.update({"name": NAME, "scan": {"frames": 12}, "dataset": {"clips": 2}, **changes})
    path.write_text(yaml.safe_dump(data))


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """(scenario, configs, datasets, out, stdout) of one study of all three models, 2 iterations each."""
    root = tmp_path_factory.mktemp("study")
    scenario, configs, datasets, out = root / "tiny.yaml", root / "configs", root / "datasets", root / "out"
    write_scenario(scenario)
    configs.mkdir()
    for fusion in ("single", "early", "late"):  # eval_every 1: a learning curve point after each iteration
        (configs / f"{fusion}.yaml").write_text(
            yaml.safe_dump(tiny_config(fusion, eval_every=1).model_dump(mode="json"))
        )
    code, stdout, stderr = run_study(scenario, "-o", out, "--datasets", datasets, "--configs", configs,
                                     "--iterations", 2, "--models", "late,single,early", "--quiet")
    assert code == 0, stderr[-2000:]
    return scenario, configs, datasets, out, stdout


def test_the_study_generates_its_dataset_with_a_val_clip(study):
    _, _, datasets, _, _ = study
    dataset = simgen.datasets.open(datasets / NAME)
    assert [dataset.split(c) for c in dataset.clips] == ["train", "val"]
    assert [dataset.num_frames(c) for c in dataset.clips] == [12, 12]


def test_table1_has_a_row_per_model_and_the_command(study):
    _, _, _, out, stdout = study
    text = (out / "table1.md").read_text()
    assert "Command: `simgen-train study " in text and "--iterations 2" in text and "Seed: 0" in text
    rows = [line for line in text.splitlines() if line.startswith("| ") and "(x1)" in line]
    assert [row.split(" | ")[0][2:] for row in rows] == list(METHODS) * 3  # IoU AP, centre-distance AP, decomposition
    assert "visible 3D" in text and "## Centre-distance AP" in text and "## Where the 3D AP goes" in text
    for row in rows[-len(METHODS):]:  # the decomposition names the costliest of the four errors
        assert row.rstrip(" |").split(" | ")[-1].split(" (")[0] in ("centre", "size", "heading", "z")
    ap = list(csv.DictReader(open(out / "table1.csv")))
    boxes = {("single", "t"), ("early", "t"), ("late", "t"), ("late", "t-1"), ("late", "t-2")}
    assert {(r["model"], r["box"]) for r in ap} == boxes
    assert {(r["truth_set"], r["iou"], r["threshold"]) for r in ap} == {
        (s, i, d) for s in ("all", "visible") for i, d in [("bev", "0.5"), ("3d", "0.5"), ("centre", "0.25"),
                                                             ("centre", "0.5"), ("centre", "1.0")]
    }
    assert all(0.0 <= float(r["ap"]) <= 100.0 and int(r["truth"]) > 0 and r["iterations"] == "2" for r in ap)
    assert str(out / "table2.md") in stdout


def test_each_model_has_a_learning_curve_on_val(study):
    _, _, _, out, _ = study
    for model in ("single", "early", "late"):
        rows = list(csv.DictReader(open(out / model / "learning_curve.csv")))
        assert [r["iteration"] for r in rows] == ["1", "2"]
        assert all(0.0 <= float(r["3d_r40"]) <= 100.0 and int(r["truth"]) > 0 for r in rows)
        assert (out / model / "learning_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = list(csv.DictReader(open(out / "table1.csv")))
    final = next(r for r in table if (r["model"], r["box"], r["iou"], r["recall_points"]) == ("late", "t", "3d", "40"))
    assert final["ap"] == rows[-1]["3d_r40"]  # the curve's last point is the table's number


def test_scoring_val_while_training_leaves_the_weights_alone(study, tmp_path):
    _, _, datasets, out, _ = study
    plain = fit(tiny_config("late", iterations=2), str(datasets / NAME), tmp_path, torch.device("cpu"), progress=False)
    a, b = load_checkpoint(out / "late" / "checkpoint.pt").model, load_checkpoint(plain.checkpoint).model
    assert all(torch.equal(a[k], b[k]) for k in b)


def test_a_checkpoint_is_reused_when_only_inference_settings_change(study, tmp_path):
    scenario, configs, datasets, out, _ = study
    shutil.copytree(out / "late", tmp_path / "out" / "late")
    shutil.copytree(configs, tmp_path / "configs")
    late = yaml.safe_load((configs / "late.yaml").read_text())
    late["infer"]["score_threshold"], late["train"]["eval_every"] = 0.3, 0
    (tmp_path / "configs" / "late.yaml").write_text(yaml.safe_dump(late))
    code, _, stderr = run_study(scenario, "-o", tmp_path / "out", "--datasets", datasets,
                                "--configs", tmp_path / "configs", "--iterations", 2, "--quiet")
    assert code == 0, stderr[-2000:]
    assert "late 2 iterations x batch 2 (checkpoint reused)" in (tmp_path / "out" / "table1.md").read_text()
    late["train"]["lr"] = 0.001  # this one changes the weights: trained again
    (tmp_path / "configs" / "late.yaml").write_text(yaml.safe_dump(late))
    code, _, stderr = run_study(scenario, "-o", tmp_path / "out", "--datasets", datasets,
                                "--configs", tmp_path / "configs", "--iterations", 2, "--quiet")
    assert code == 0 and "(checkpoint reused)" not in (tmp_path / "out" / "table1.md").read_text()


def test_the_paper_preset_runs_table1s_five_rows_and_table2(study, tmp_path, monkeypatch):
    """`--preset paper` at tiny size: the paper's configs and scenarios swapped for tiny ones, same loop."""
    import train.cli

    scenario, configs, datasets, _, _ = study
    folder = tmp_path / "scenarios"
    folder.mkdir()
    shutil.copy(scenario, folder / "tiny.yaml")
    write_scenario(folder / "tiny_x2.yaml", name=NAME + "_x2", scan={"frames": 12, "density": 2})
    monkeypatch.setitem(train.cli.PRESETS, "paper", (configs, (("tiny.yaml", ("single", "early", "late")),
                                                               ("tiny_x2.yaml", ("single", "late")))))
    monkeypatch.setattr(train.cli, "SCENARIOS", folder)
    code, _, stderr = run_study("--preset", "paper", "-o", tmp_path / "out", "--datasets", datasets, "--iterations", 1,
                                     "--quiet")
    assert code == 0, stderr[-2000:]
    for name, methods in (("tiny", METHODS), ("tiny_x2", ("Single Frame (x2)", "Late Fusion (x2)"))):
        tables = (tmp_path / "out" / name / "table1.md").read_text().split("\n\n")  # all boxes, visible boxes, ...
        rows = [
            [
                line.split(" | ")[0][2:]
                for line in table.splitlines()
                if line.startswith("| ") and " (x" in line.split(" | ")[0]
            ]
            for table in tables
        ]
        assert [r for r in rows if r] and all(r == list(methods) for r in rows if r)
        assert (tmp_path / "out" / name / "table2.md").is_file()


def test_preset_and_scenario_are_exclusive(study):
    scenario, _, _, _, _ = study
    code, _, stderr = run_study(scenario, "--preset", "paper", "-o", "unused")
    assert code == 2 and stderr.count("\n") == 1 and "not both" in stderr
    code, _, stderr = run_study("-o", "unused")
    assert code == 2 and stderr.count("\n") == 1 and "give a scenario YAML or --preset" in stderr


def test_table2_has_every_tracker_at_both_ious(study):
    _, _, _, out, _ = study
    text = (out / "table2.md").read_text()
    assert (
        "## 3D IoU >= 0.25, filtered tracklets" in text
        and "## 3D IoU >= 0.5, unfiltered tracklets, for comparison" in text
    )
    assert "each tracker gets its own filter, chosen on the train clips" in text
    rows = list(csv.DictReader(open(out / "table2.csv")))
    names = [c.name for c in load_tracker_configs(TRACKER_CONFIGS)]
    # Each tracker's own filter: a row of the filter table, the one its filtered CSV rows name, and the bold
    # (best) cell of its column in the grid chosen on the train clips.
    lines = text.splitlines()
    own_table = lines[lines.index("| Method | tracklet filter | val tracklets per frame |") + 2:]
    own = dict(line[2:-2].split(" | ")[:2] for line in own_table[:own_table.index("")])
    assert list(own) == names
    assert all(r["filter"] == own[r["tracker"]] for r in rows if r["tracklets"] == "filtered")
    grid = lines[lines.index("| Filter | tracklets per frame | " + " | ".join(names) + " |"):]
    cells = [line[2:-2].split(" | ") for line in grid[2:] if line.startswith("| ")]
    for column, name in enumerate(names, start=2):
        bold = [row[0] for row in cells if row[column].startswith("**")]
        assert bold == [own[name]], (name, bold)
        best = max(float(row[column].strip("*")) for row in cells)
        assert float(next(row[column] for row in cells if row[0] == own[name]).strip("*")) == best
    assert [(r["tracker"], r["tracklets"], r["min_iou"]) for r in rows] == [
        (name, kind, iou) for kind in ("filtered", "unfiltered") for name in names for iou in ("0.25", "0.5")
    ]
    assert names[:3] == ["AB3DMOT", "AB3DMOT (player Kalman)", "3D DIoU"] and names[-1] == FULL_TRACKER
    assert all(
        0.0 <= float(r[k]) <= 1.0 for r in rows for k in ("samota", "amota", "amotp", "motp", "hota", "centre_hota")
    )
    assert all(int(r["n_gt"]) > 0 and int(r["tp"]) + int(r["fn"]) == int(r["n_gt"]) for r in rows)
    assert (out / "late" / "tracklets" / "clip_0001.npz").is_file()


def test_track_scores_a_studys_tracklet_files_as_the_study_did(study, tmp_path):
    """`simgen-train table2` on the study's val tracklets: the same ground truth, so the unfiltered rows are the
    study's; the filters are chosen on the tracked clip itself (said so), and the module accounting is there."""
    _, configs, datasets, out, _ = study
    tracklets = out / "late" / "tracklets" / "clip_0001.npz"
    code, stdout, stderr = run_main(main, "table2", tracklets, "--dataset", datasets / NAME,
                                    "--config", configs / "late.yaml", "-o", tmp_path / "track", "--quiet")
    assert code == 0, stderr[-2000:]
    assert stdout.split() == [str(tmp_path / "track" / "table2.md"), str(tmp_path / "track" / "table2.csv")]
    text = (tmp_path / "track" / "table2.md").read_text()
    assert "chosen on the tracked clips themselves" in text and "Command: `simgen-train table2 " in text
    assert f"| {FULL_TRACKER} | " in text.split("## What birth/death and split do")[1]
    unfiltered = [{k: v for k, v in r.items() if k != "filter"}
                  for r in csv.DictReader(open(out / "table2.csv")) if r["tracklets"] == "unfiltered"]
    again = [{k: v for k, v in r.items() if k != "filter"}
             for r in csv.DictReader(open(tmp_path / "track" / "table2.csv")) if r["tracklets"] == "unfiltered"]
    assert again == unfiltered and unfiltered


def test_table2_by_zone_counts_every_labelled_box_in_one_zone(study, tmp_path):
    _, configs, datasets, out, _ = study
    tracklets = sorted((out / "late" / "tracklets").iterdir())
    code, stdout, stderr = run_main(main, "table2", *tracklets, "--dataset", datasets / NAME, "--config",
                                    configs / "late.yaml", "-o", tmp_path / "zones", "--quiet", "--by-zone",
                                    "--filters-from", out / "table2.csv")
    assert code == 0, stderr[-2000:]
    assert str(tmp_path / "zones" / "table2_by_zone.csv") in stdout.split()
    whole = {(r["tracker"], r["min_iou"]): int(r["n_gt"])
             for r in csv.DictReader(open(tmp_path / "zones" / "table2.csv")) if r["tracklets"] == "filtered"}
    zoned = list(csv.DictReader(open(tmp_path / "zones" / "table2_by_zone.csv")))
    assert zoned and {r["zone"] for r in zoned} <= {"paper box", "outside"}
    for key, n_gt in whole.items():
        assert sum(int(r["n_gt"]) for r in zoned if (r["tracker"], r["min_iou"]) == key) == n_gt
    assert "## By pitch zone" in (tmp_path / "zones" / "table2.md").read_text()


def test_track_refuses_a_clip_the_dataset_lacks_in_one_line(study, tmp_path):
    _, configs, datasets, out, _ = study
    stray = tmp_path / "stray.npz"
    data = dict(np.load(out / "late" / "tracklets" / "clip_0001.npz"))
    np.savez(stray, **{**data, "clip": np.str_("clip_0009")})
    code, stdout, stderr = run_main(main, "table2", stray, "--dataset", datasets / NAME,
                                    "--config", configs / "late.yaml", "-o", tmp_path / "track", "--quiet")
    assert_one_line_refusal(code, stdout, stderr, "stray clip")
    assert "clip_0009" in stderr and not (tmp_path / "track").exists()


def test_track_reads_a_studys_filters_and_refuses_bad_ones_in_one_line(study, tmp_path):
    _, configs, datasets, out, _ = study
    tracklets = out / "late" / "tracklets" / "clip_0001.npz"
    common = ("--dataset", datasets / NAME, "--config", configs / "late.yaml", "--quiet")
    code, _, stderr = run_main(main, "table2", tracklets, *common, "-o", tmp_path / "given", "--filters-from",
                               out / "table2.csv")
    assert code == 0, stderr[-2000:]
    given = {r["tracker"]: r["filter"] for r in csv.DictReader(open(tmp_path / "given" / "table2.csv"))
             if r["tracklets"] == "filtered"}
    assert given == {r["tracker"]: r["filter"] for r in csv.DictReader(open(out / "table2.csv"))
                     if r["tracklets"] == "filtered"}
    assert "## Choosing the tracklet filters" not in (tmp_path / "given" / "table2.md").read_text()
    (tmp_path / "bad.csv").write_text("tracker,tracklets,filter\nAB3DMOT,filtered,no such filter\n")
    for extra, said in (((("--filters-from", tmp_path / "bad.csv")), "not a study's table2.csv"),
                        (("--filters-from", out / "table2.csv", "--choose-on", tracklets), "not both"),
                        (("--filters-from", tmp_path / "missing.csv"), "missing.csv")):
        code, stdout, stderr = run_main(main, "table2", tracklets, *common, "-o", tmp_path / "bad", *extra)
        assert_one_line_refusal(code, stdout, stderr, extra)
        assert said in stderr and not (tmp_path / "bad").exists()


def test_a_second_study_reuses_the_dataset_and_the_late_checkpoint(study):
    scenario, configs, datasets, out, _ = study
    code, _, stderr = run_study(
        scenario, "-o", out, "--datasets", datasets, "--configs", configs, "--iterations", 2, "--quiet"
    )
    assert code == 0, stderr[-2000:]
    text = (out / "table1.md").read_text()
    assert "reused (same resolved scenario)" in text and "late 2 iterations x batch 2 (checkpoint reused)" in text
    assert next(line for line in text.splitlines() if "(x1) |" in line).startswith("| Late Fusion (x1) |")


@pytest.mark.parametrize(
    "args, message",
    [
        (("{tmp}/missing.yaml", "-o", "{tmp}/out"), "no such scenario file"),
        (("{scenario}", "-o", "{tmp}/out", "--models", "late,pointnet"), "unknown model 'pointnet'"),
        (("{scenario}", "-o", "{tmp}/out", "--models", "single"), "needs 'late'"),
        ((str(PAPER_X2), "-o", "{tmp}/out", "--models", "late,early"), "no 'early' row at density x2"),
        (("{scenario}", "-o", "{tmp}/out", "--iterations", "0"), "--iterations: 0"),
        (("{tmp}/other.yaml", "-o", "{tmp}/out", "--datasets", "{datasets}"), "holds a dataset of another scenario"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(study, tmp_path, args, message):
    scenario, _, datasets, _, _ = study
    write_scenario(tmp_path / "other.yaml", seed=8)
    code, _, stderr = run_study(*(a.format(tmp=tmp_path, scenario=scenario, datasets=datasets) for a in args))
    assert code == 2, stderr
    assert stderr.count("\n") == 1 and message in stderr, stderr


def test_seeds_and_the_frame_split(study, tmp_path):
    """--seeds 0,1 with --split frame: a study per seed in OUT/seed_<seed>/ (their configs' seeds and split as
    asked), Table 1 over the seeds with the ordering verdict, and Table 2 not run (no val clip to track)."""
    scenario, configs, datasets, _, _ = study
    out = tmp_path / "seeds"
    code, _, stderr = run_study(scenario, "-o", out, "--datasets", datasets, "--configs", configs, "--iterations", 2,
                                "--models", "late,single", "--seeds", "0,1", "--split", "frame", "--quiet")
    assert code == 0, stderr[-2000:]
    for seed in (0, 1):
        config = load_checkpoint(out / f"seed_{seed}" / "late" / "checkpoint.pt").config
        assert (config.seed, config.data.split) == (seed, "frame")
        seed_table1 = (out / f"seed_{seed}" / "table1.md").read_text()
        assert "Split: by frame" in seed_table1 and "val windows drawn from all 2 clips" in seed_table1
        assert "Not run: with the frame split" in (out / f"seed_{seed}" / "table2.md").read_text()
    table1 = (out / "table1.md").read_text()
    assert "over training seeds 0, 1" in table1 and "Late Fusion > Single Frame: holds in" in table1
    rows = [line for line in table1.splitlines() if line.startswith(("| Late Fusion", "| Single Frame"))]
    assert len(rows) == 2 and all(" ± " in row for row in rows)
    assert "Not run" in (out / "table2.md").read_text()
    code, _, stderr = run_study(scenario, "-o", out, "--seeds", "0,0", "--quiet")
    assert code == 2 and stderr.strip().endswith("seed 0 is given twice")
