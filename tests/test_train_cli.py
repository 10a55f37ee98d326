"""`simgen-train fit | eval | detect | score` end to end on a small real dataset, and its one-line errors."""

import csv
import subprocess
import sys

import numpy as np
import pytest
import yaml

from tests.support import ROOT
from tests.support.detector import smoke_dataset, tiny_config
from train.cli import main
from train.detector.detections import read_tracklets


def run_train(*args: object) -> subprocess.CompletedProcess:
    """The CLI as a user runs it, in its own process."""
    return subprocess.run(
        [sys.executable, "-m", "train.cli", *map(str, args)], capture_output=True, text=True, cwd=ROOT, timeout=300
    )


def call_train(capsys, *args: object) -> tuple[int, str]:
    """The CLI's entry point in this process (no torch import per call): exit code and stderr."""
    code = main([str(a) for a in args])
    return code, capsys.readouterr().err


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A tiny late-fusion model fitted for 2 iterations; (dataset, run folder)."""
    dataset = smoke_dataset(tmp_path_factory.getbasetemp(), 6)
    run = tmp_path_factory.mktemp("run")
    config = run / "tiny.yaml"
    config.write_text(yaml.safe_dump(tiny_config("late").model_dump(mode="json")))
    result = run_train("fit", config, "--dataset", dataset, "-o", run, "--iterations", 2, "--quiet")
    assert result.returncode == 0, result.stderr
    return dataset, run


@pytest.mark.engine  # the `trained` fixture generates its dataset with the engine
def test_fit_writes_a_checkpoint_and_a_loss_log(trained):
    _, run = trained
    assert (run / "checkpoint.pt").is_file()
    rows = list(csv.DictReader(open(run / "train_log.csv")))
    assert [r["iteration"] for r in rows] == ["1", "2"]
    assert {"loss", "loss_cls", "loss_dir", "loss_loc_0", "loss_loc_2", "lr", "samples_per_s"} <= set(rows[0])


@pytest.mark.engine
def test_bf16_autocast_trains_on_cpu(trained, tmp_path):
    """The CUDA path's bfloat16 autocast, forced on CPU: finite weights, other than float32's."""
    import torch

    from train.checkpoint import load_checkpoint
    from train.fit import fit

    dataset, run = trained
    bf16 = fit(
        tiny_config("late", iterations=2, bf16="on"), str(dataset), tmp_path, torch.device("cpu"), progress=False
    )
    weights, plain = load_checkpoint(bf16.checkpoint).model, load_checkpoint(run / "checkpoint.pt").model
    assert all(torch.isfinite(w).all() for w in weights.values() if w.is_floating_point())
    assert not all(torch.equal(weights[k], plain[k]) for k in plain)


@pytest.mark.engine
def test_a_learning_curve_without_val_clips_fails_before_training(trained, tmp_path, capsys):
    dataset, _ = trained
    config = tmp_path / "curve.yaml"
    config.write_text(yaml.safe_dump(tiny_config("late", eval_every=1).model_dump(mode="json")))
    code, err = call_train(capsys, "fit", config, "--dataset", dataset, "-o", tmp_path / "run", "--quiet")
    assert code == 2 and err.count("\n") == 1 and "no clips in the 'val' split" in err
    assert not (tmp_path / "run" / "checkpoint.pt").exists()


def _on_every_clip(capsys, command: str, run, dataset, out):
    """`simgen-train COMMAND` of the run's checkpoint on every clip of the dataset, output in OUT."""
    checkpoint = run / "checkpoint.pt"
    return call_train(capsys, command, checkpoint, "--dataset", dataset, "-o", out, "--split", "all", "--quiet")


@pytest.mark.engine
def test_eval_writes_ap_for_the_three_boxes(trained, tmp_path, capsys):
    dataset, run = trained
    code, err = _on_every_clip(capsys, "eval", run, dataset, tmp_path)
    assert code == 0, err
    rows = list(csv.DictReader(open(tmp_path / "ap.csv")))
    measures = [("bev", "0.5"), ("3d", "0.5"), ("centre", "0.25"), ("centre", "0.5"), ("centre", "1.0")]
    assert {(r["truth_set"], r["box"], r["iou"], r["threshold"], r["recall_points"]) for r in rows} == {
        (s, b, i, d, p)
        for s in ("all", "visible")
        for b in ("t", "t-1", "t-2")
        for i, d in measures
        for p in ("40", "11")
    }
    assert all(0.0 <= float(r["ap"]) <= 100.0 and int(r["truth"]) > 0 for r in rows)
    truth = {(r["truth_set"], r["box"]): int(r["truth"]) for r in rows}
    assert truth[("visible", "t")] <= truth[("all", "t")]


@pytest.mark.engine
def test_detect_writes_tracklets_and_kitti_labels(trained, tmp_path, capsys):
    dataset, run = trained
    code, err = _on_every_clip(capsys, "detect", run, dataset, tmp_path)
    assert code == 0, err
    tracklets = read_tracklets(tmp_path / "tracklets" / "clip_0000.npz")
    assert tracklets.boxes.shape[1:] == (3, 7) and tracklets.offsets.tolist() == [-2, -1, 0]
    assert len(tracklets.frame) == len(tracklets.scores) and np.all(np.diff(tracklets.frame) >= 0)
    assert ((tracklets.scores >= 0) & (tracklets.scores <= 1)).all()
    labels = sorted((tmp_path / "kitti" / "clip_0000").iterdir())
    assert [p.name for p in labels] == [f"{i:06d}.txt" for i in range(2, 6)]
    lines = [line.split() for p in labels for line in p.read_text().splitlines()]
    assert len(lines) == len(tracklets.frame) and all(len(f) == 16 and f[0] == "Pedestrian" for f in lines)


@pytest.mark.engine
def test_score_of_detects_tracklets_is_evals_ap_with_distance_bins(trained, tmp_path, capsys):
    """`score` of the tracklet files `detect` wrote reads the same AP as `eval` of the checkpoint, by distance and by
    zone too; each labelled box counts in one bin and one zone."""
    dataset, run = trained
    checkpoint = run / "checkpoint.pt"
    for command in ("eval", "detect"):
        code, err = call_train(capsys, command, checkpoint, "--dataset", dataset, "-o", tmp_path / command, "--split",
                               "all", "--quiet", *(["--by-distance", 20, "--by-zone"] if command == "eval" else []))
        assert code == 0, err
    tracklets = sorted((tmp_path / "detect" / "tracklets").iterdir())
    code, err = call_train(capsys, "score", *tracklets, "--dataset", dataset, "--config", run / "tiny.yaml", "-o",
                           tmp_path / "score", "--by-distance", 20, "--by-zone")
    assert code == 0, err

    def table(folder, name, extra):
        return [r[extra:] for r in csv.reader(open(tmp_path / folder / name))][1:]

    assert table("score", "ap.csv", 2) == table("eval", "ap.csv", 3)
    assert table("score", "ap_by_distance.csv", 2) == table("eval", "ap_by_distance.csv", 3)
    bins = list(csv.DictReader(open(tmp_path / "score" / "ap_by_distance.csv")))
    assert {float(r["high_m"]) - float(r["low_m"]) for r in bins} == {20.0}
    total = next(r for r in csv.DictReader(open(tmp_path / "score" / "ap.csv"))
                 if (r["truth_set"], r["box"], r["iou"], r["recall_points"]) == ("all", "t", "3d", "40"))
    assert sum(int(r["truth"]) for r in bins if (r["iou"], r["recall_points"]) == ("3d", "40")) == int(total["truth"])
    assert table("score", "ap_by_zone.csv", 2) == table("eval", "ap_by_zone.csv", 3)
    zones = [r for r in csv.DictReader(open(tmp_path / "score" / "ap_by_zone.csv"))
             if (r["iou"], r["recall_points"]) == ("3d", "40")]
    assert {r["zone"] for r in zones} <= {"paper box", "outside"} and zones
    assert sum(int(r["truth"]) for r in zones) == int(total["truth"])


@pytest.mark.engine
@pytest.mark.parametrize(
    "args, message",
    [
        (("fit", "train/configs/late.yaml", "--dataset", "/nonexistent/ds", "-o", "{tmp}"), "/nonexistent/ds"),
        (("fit", "{tmp}/missing.yaml", "--dataset", "{dataset}", "-o", "{tmp}"), "no such config file"),
        (("eval", "{tmp}/garbage.pt", "--dataset", "{dataset}", "-o", "{tmp}"), "not a simgen-train checkpoint"),
        (("eval", "{run}/checkpoint.pt", "--dataset", "{dataset}", "-o", "{tmp}"), "no clips in the 'val' split"),
        (("detect", "{tmp}/none.pt", "--dataset", "{dataset}", "-o", "{tmp}"), "no such checkpoint file"),
        (("score", "{tmp}/garbage.pt", "--dataset", "{dataset}", "--config", "train/configs/late.yaml", "-o",
          "{tmp}/out"), "not a tracklet file"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(trained, tmp_path, capsys, args, message):
    dataset, run = trained
    (tmp_path / "garbage.pt").write_bytes(b"\x80\x02not a checkpoint")
    code, err = call_train(capsys, *(a.format(tmp=tmp_path, dataset=dataset, run=run) for a in args))
    assert code == 2
    assert err.count("\n") == 1 and message in err, err


@pytest.mark.parametrize("args", [["fit"], ["score", "t.npz", "--dataset", "d", "--config", "c", "-o", "o",
                                            "--by-distance", "0"]])
def test_usage_errors_are_one_line(capsys, args):
    with pytest.raises(SystemExit) as exit_:
        main(args)
    assert exit_.value.code == 2 and capsys.readouterr().err.count("\n") == 1


@pytest.mark.engine
def test_a_fit_stopped_and_resumed_ends_with_the_uninterrupted_weights(trained, tmp_path, capsys):
    """6 iterations at once, and the same fit stopped at 2 then resumed (with a learning curve and a log
    every iteration): equal weights, optimiser state and learning curve; the log goes on where it stopped."""
    import torch

    from train.checkpoint import load_checkpoint

    dataset, _ = trained
    raw = tiny_config("late", iterations=6, eval_every=3).model_dump(mode="json")
    raw["data"]["split"] = "frame"  # a val window in the one-clip dataset, for the learning curve
    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump(raw))
    whole, parts = tmp_path / "whole", tmp_path / "parts"
    assert call_train(capsys, "fit", config, "--dataset", dataset, "-o", whole, "--quiet")[0] == 0
    assert call_train(capsys, "fit", config, "--dataset", dataset, "-o", parts, "--quiet", "--stop-at", 2)[0] == 0
    assert load_checkpoint(parts / "checkpoint.pt").iteration == 2
    assert call_train(capsys, "fit", config, "--dataset", dataset, "-o", parts, "--quiet", "--resume")[0] == 0
    a, b = load_checkpoint(whole / "checkpoint.pt"), load_checkpoint(parts / "checkpoint.pt")
    assert a.iteration == b.iteration == 6
    for name, weight in a.model.items():
        assert torch.equal(weight, b.model[name]), name
    assert a.optimizer["state"].keys() == b.optimizer["state"].keys()
    for key, state in a.optimizer["state"].items():
        assert all(torch.equal(v, b.optimizer["state"][key][k]) for k, v in state.items())
    assert [r["iteration"] for r in csv.DictReader(open(parts / "train_log.csv"))] == [str(i) for i in range(1, 7)]
    curve = [(r["iteration"], r["3d_r40"]) for r in csv.DictReader(open(parts / "learning_curve.csv"))]
    assert curve == [(r["iteration"], r["3d_r40"]) for r in csv.DictReader(open(whole / "learning_curve.csv"))]
    code, err = call_train(capsys, "fit", config, "--dataset", dataset, "-o", parts, "--quiet", "--resume")
    assert code == 2 and err.strip().endswith("at iteration 6 of 'train.iterations' 6: nothing to resume")
