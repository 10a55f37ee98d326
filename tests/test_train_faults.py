"""Faults around a training run (issue 43): one writer per run folder, no run replaced unasked, a log
appended and checked on resume, checkpoints checked before use, stale temporary files removed, nothing
left by a refused command, and no process left by a killed `fit` (its loader workers) or `study` (its
`simgen generate`). Real processes where the fault is a process's death; the CLI's `main` in this
process elsewhere."""

from __future__ import annotations

import csv
import functools
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from dataclasses import replace
from pathlib import Path

import pytest
import torch
import yaml

from tests.support import ROOT
from tests.support.detector import SMOKE, smoke_dataset, tiny_config
from tests.support.hostile import assert_one_line_refusal, run_main
from train.checkpoint import load_checkpoint, save_checkpoint
from train.cli import main
from train.fit import CHECKPOINT_NAME, LOG_NAME

pytestmark = pytest.mark.engine  # the dataset is generated with the engine

ITERATIONS = 4
KILL_CYCLES = 4  # kill/resume cycles of `fit --workers 2`
GONE_S = 10.0  # how long the processes of a killed parent may take to go
FLIPS = 300  # random single-bit flips of a checkpoint


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> dict[str, Path]:
    """The smoke dataset, a tiny config (4 iterations, a log row and a checkpoint every iteration), and an
    uninterrupted run of it."""
    dataset = smoke_dataset(tmp_path_factory.getbasetemp(), 6)
    root = tmp_path_factory.mktemp("train_faults")
    config = root / "tiny.yaml"
    config.write_text(yaml.safe_dump(tiny_config("late", iterations=ITERATIONS, checkpoint_every=1)
                                     .model_dump(mode="json")))
    whole = root / "whole"
    code, _, err = run_main(main, "fit", config, "--dataset", dataset, "-o", whole, "--quiet")
    assert code == 0, err
    return {"dataset": dataset, "config": config, "whole": whole}


def _fit(world: dict[str, Path], out: Path, *options: object) -> tuple[int, str, str]:
    return run_main(main, "fit", world["config"], "--dataset", world["dataset"], "-o", out, "--quiet", *options)


def _stopped(world: dict[str, Path], out: Path, at: int = 2) -> Path:
    """A run stopped (checkpointed) at iteration `at`."""
    code, _, err = _fit(world, out, "--stop-at", at)
    assert code == 0, err
    return out


def _log(run: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(open(run / LOG_NAME, newline="")))


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _train_process(world: dict[str, Path], out: Path, *options: object) -> subprocess.Popen:
    """`simgen-train fit` in its own process and session (its session id is its pid)."""
    command = [sys.executable, "-m", "train.cli", "fit", str(world["config"]), "--dataset", str(world["dataset"]),
               "-o", str(out), "--quiet", *map(str, options)]
    return subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)


def _session(sid: int) -> list[tuple[int, str]]:
    """(pid, command line) of the live processes (zombies aside) of session `sid`."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # state, ppid, pgrp, session, ...
        if int(fields[3]) == sid and fields[0] != "Z":
            found.append((int(entry.name), command))
    return found


def _wait(condition, seconds: float, what: str) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def _left_after(process: subprocess.Popen) -> list[tuple[int, str]]:
    """SIGKILL `process` alone (not its group), reap it, and return what of its session is still alive
    GONE_S later (nothing, once everything has gone)."""
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    deadline = time.monotonic() + GONE_S
    while _session(process.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = _session(process.pid)
    for pid, _ in left:  # not to leave them to the next test
        os.kill(pid, signal.SIGKILL)
    return left


# --- one writer per run folder ------------------------------------------------------------------


def test_a_second_writer_is_refused_while_the_first_writes(world, tmp_path):
    """Two fits into one folder: the second is refused in one line naming the first's pid; once the first
    is killed, its lock is gone with it and the run resumes."""
    run = tmp_path / "run"
    config = world["config"]
    longer = tmp_path / "longer.yaml"
    raw = yaml.safe_load(config.read_text())
    raw["train"]["iterations"] = 100_000
    longer.write_text(yaml.safe_dump(raw))
    first = _train_process({**world, "config": longer}, run)
    try:
        _wait(lambda: (run / CHECKPOINT_NAME).is_file() or first.poll() is not None, 120, "the first checkpoint")
        assert first.poll() is None, first.stderr.read().decode()
        code, out, err = run_main(main, "fit", longer, "--dataset", world["dataset"], "-o", run, "--quiet",
                                  "--resume", "--stop-at", load_checkpoint(run / CHECKPOINT_NAME).iteration + 1)
        assert_one_line_refusal(code, out, err, "a second writer")
        assert f"another simgen-train fit is writing here (pid {first.pid} " in err
    finally:
        assert _left_after(first) == []
    code, _, err = run_main(main, "fit", longer, "--dataset", world["dataset"], "-o", run, "--quiet", "--resume",
                            "--stop-at", load_checkpoint(run / CHECKPOINT_NAME).iteration + 1)
    assert code == 0, err
    assert not (run / ".lock").exists()


# --- a folder holding a run ---------------------------------------------------------------------


def test_fit_refuses_a_folder_holding_a_run_unless_resumed_or_overwritten(world, tmp_path):
    run = _stopped(world, tmp_path / "run")
    before = _snapshot(run)
    code, out, err = _fit(world, run)
    assert_one_line_refusal(code, out, err, "a plain fit into a run")
    assert "holds a training run (checkpoint.pt); --resume continues it, --overwrite replaces it" in err
    code, out, err = _fit(world, run, "--resume", "--overwrite")
    assert_one_line_refusal(code, out, err, "--resume --overwrite")
    assert _snapshot(run) == before
    (run / CHECKPOINT_NAME).unlink()  # a run killed before its first checkpoint: its log alone
    code, out, err = _fit(world, run)
    assert_one_line_refusal(code, out, err, "a plain fit into a log")
    assert "holds a training run (train_log.csv)" in err
    code, _, err = _fit(world, run, "--overwrite")
    assert code == 0, err
    assert [r["iteration"] for r in _log(run)] == [str(i) for i in range(1, ITERATIONS + 1)]
    assert load_checkpoint(run / CHECKPOINT_NAME).iteration == ITERATIONS


# --- the log: appended, on disk with each checkpoint, checked on resume -------------------------


def test_a_resumed_fit_appends_to_its_log_and_drops_a_torn_last_row(world, tmp_path):
    """A fit killed after writing row 3 and part of row 4 past its checkpoint at 2: the resumed fit says
    it dropped the torn row, keeps the first rows' bytes where they were (same file), and ends with the
    uninterrupted run's log and weights."""
    run = _stopped(world, tmp_path / "run")
    kept = (run / LOG_NAME).read_bytes()
    inode = (run / LOG_NAME).stat().st_ino
    whole_rows = (world["whole"] / LOG_NAME).read_bytes().split(b"\r\n")
    with open(run / LOG_NAME, "ab") as log:
        log.write(whole_rows[3] + b"\r\n" + whole_rows[4][:9])
    code, _, err = _fit(world, run, "--resume")
    assert code == 0, err
    assert err == f"{run / LOG_NAME}: dropped its torn last row (written as the fit was killed)\n"
    assert (run / LOG_NAME).stat().st_ino == inode and (run / LOG_NAME).read_bytes().startswith(kept)
    columns = ("iteration", "lr", "loss", "loss_cls", "loss_dir", "loss_loc_0", "loss_loc_2")
    assert [[r[c] for c in columns] for r in _log(run)] == [[r[c] for c in columns] for r in _log(world["whole"])]
    a, b = load_checkpoint(run / CHECKPOINT_NAME).model, load_checkpoint(world["whole"] / CHECKPOINT_NAME).model
    assert all(torch.equal(a[k], b[k]) for k in a)


def _cut_mid_row(log: bytes) -> bytes:
    return log[: log.rindex(b"\r\n", 0, len(log) - 2) + 12]


def _cut_at_a_field(log: bytes) -> bytes:
    return log[: log.rindex(b",", 0, len(log) - 2)]


BAD_LOGS = {
    "missing": (None, "missing or not a file; a resumed fit goes on with its log"),
    "garbage": (lambda log: b"\x00\xff garbage \x80" * 50, "its first line is not this training's header"),
    "another header": (lambda log: log.replace(b"loss_cls", b"loss_xyz", 1), "is not this training's header"),
    "cut mid-row": (_cut_mid_row, "line 3 is not a whole row of an iteration after 1, up to the checkpoint's 2"),
    "cut at a field": (_cut_at_a_field, "line 3 is not a whole row of an iteration after 1"),
    "a row missing": (lambda log: b"\r\n".join(log.split(b"\r\n")[:1] + log.split(b"\r\n")[2:]),
                      "line 3 is not a whole row of an iteration after 2"),
    "a row not numbers": (lambda log: log.replace(b"\r\n2,", b"\r\n2,x", 1), "line 3 is not a whole row"),
    "a directory": (None, "not a regular file, as a run's train_log.csv is; move it out"),
}


@pytest.mark.parametrize("case", sorted(BAD_LOGS))
def test_a_resumed_fit_refuses_a_damaged_log_in_one_line(world, tmp_path, case):
    """Rows up to the checkpoint's iteration are on disk before it: any of them missing or damaged is a
    damaged log, refused in one line naming the line, the run left as it was."""
    run = _stopped(world, tmp_path / "run")
    change, message = BAD_LOGS[case]
    log = (run / LOG_NAME).read_bytes()
    (run / LOG_NAME).unlink()
    if case == "a directory":
        (run / LOG_NAME).mkdir()
    elif change is not None:
        (run / LOG_NAME).write_bytes(change(log))
    before = _snapshot(run)
    code, out, err = _fit(world, run, "--resume")
    assert_one_line_refusal(code, out, err, case)
    assert message in err, err
    # a log the fit can replace is answered with --overwrite; a folder in its place must be moved out by hand
    assert ("--overwrite starts the run again" in err) == (case != "a directory"), err
    assert _snapshot(run) == before


def test_a_checkpoint_from_before_log_bytes_resumes_by_log_every(world, tmp_path):
    """A checkpoint that does not record its log's length (written before it did): the rows up to it are one
    every `train.log_every` iterations; the fit resumes to the uninterrupted log, and a cut log is refused."""
    run = _stopped(world, tmp_path / "run")
    old = replace(load_checkpoint(run / CHECKPOINT_NAME), log_bytes=None)
    save_checkpoint(run / CHECKPOINT_NAME, old)
    log = (run / LOG_NAME).read_bytes()
    (run / LOG_NAME).write_bytes(_cut_mid_row(log))
    code, out, err = _fit(world, run, "--resume")
    assert_one_line_refusal(code, out, err, "a cut log, an older checkpoint")
    assert "line 3 is not a whole row of an iteration after 1, up to the checkpoint's 2" in err
    (run / LOG_NAME).write_bytes(log)
    code, _, err = _fit(world, run, "--resume")
    assert code == 0, err
    assert [r["loss"] for r in _log(run)] == [r["loss"] for r in _log(world["whole"])]


# --- checkpoints checked before use -------------------------------------------------------------


def _flipped(source: Path, target: Path, offset: int, bit: int) -> Path:
    data = bytearray(source.read_bytes())
    data[offset] ^= 1 << bit
    target.write_bytes(bytes(data))
    return target


def _member_data(path: Path, name_ends: str) -> tuple[int, int]:
    """(offset, size) in the file of a zip member's bytes."""
    with zipfile.ZipFile(path) as archive:
        info = next(m for m in archive.infolist() if m.filename.endswith(name_ends))
    with open(path, "rb") as file:
        file.seek(info.header_offset + 26)
        name, extra = (int.from_bytes(file.read(2), "little") for _ in range(2))
    return info.header_offset + 30 + name + extra, info.compress_size


def test_a_bit_flipped_checkpoint_is_refused_before_use(world, tmp_path):
    """One bit flipped in a weight: `eval`, `detect` and `fit --resume` refuse it in one line naming the
    member whose CRC-32 fails, and write nothing."""
    run = _stopped(world, tmp_path / "run")
    checkpoint = run / CHECKPOINT_NAME
    with zipfile.ZipFile(checkpoint) as archive:
        largest = max(archive.infolist(), key=lambda m: m.compress_size).filename
    offset, size = _member_data(checkpoint, largest)
    _flipped(checkpoint, checkpoint, offset + size // 2, 3)
    before = _snapshot(run)
    for command in ("eval", "detect"):
        code, out, err = run_main(main, command, checkpoint, "--dataset", world["dataset"], "-o", tmp_path / command,
                                  "--split", "all", "--quiet")
        assert_one_line_refusal(code, out, err, command)
        assert f"a damaged checkpoint (its member {largest!r} fails its CRC-32 check" in err
        assert not (tmp_path / command).exists()
    code, out, err = _fit(world, run, "--resume")
    assert_one_line_refusal(code, out, err, "fit --resume")
    assert "a damaged checkpoint" in err and _snapshot(run) == before


def test_every_bit_flip_that_changes_what_torch_reads_is_refused(world, tmp_path):
    """FLIPS random bits anywhere in a checkpoint: each one is either refused in one line (`UserError`) or
    leaves torch.load reading exactly the same payload (a flip in a field nothing reads)."""
    from simgen.errors import UserError

    source = world["whole"] / CHECKPOINT_NAME
    reference = torch.load(source, weights_only=True)
    size, chance = source.stat().st_size, random.Random(43)
    refused = 0
    for _ in range(FLIPS):
        offset, bit = chance.randrange(size), chance.randrange(8)
        flipped = _flipped(source, tmp_path / "flipped.pt", offset, bit)
        try:
            load_checkpoint(flipped)
        except UserError as error:
            assert "\n" not in str(error)
            refused += 1
            continue
        assert _same(torch.load(flipped, weights_only=True), reference), (offset, bit)
    print(f"{refused} of {FLIPS} flips refused, the rest read the same")
    assert refused > 0.8 * FLIPS


def _same(a: object, b: object) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, torch.Tensor):
        return isinstance(b, torch.Tensor) and a.dtype == b.dtype and torch.equal(a, b)
    return a == b


def test_a_plain_pickle_or_a_folder_as_checkpoint_is_one_line(world, tmp_path):
    """A plain pickle (a real process: torch's warning would be a second line) and a folder named
    checkpoint.pt."""
    pickled = tmp_path / "plain.pt"
    torch.save({"format": "simgen-train/detector"}, pickled, _use_new_zipfile_serialization=False)
    done = subprocess.run([sys.executable, "-m", "train.cli", "eval", str(pickled), "--dataset", str(world["dataset"]),
                           "-o", str(tmp_path / "out"), "--quiet"], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    assert_one_line_refusal(done.returncode, done.stdout, done.stderr, "a plain pickle")
    assert "not a simgen-train checkpoint (not the zip archive torch.save writes)" in done.stderr
    (tmp_path / "folder" / CHECKPOINT_NAME).mkdir(parents=True)
    code, out, err = run_main(main, "eval", tmp_path / "folder" / CHECKPOINT_NAME, "--dataset", world["dataset"],
                              "-o", tmp_path / "out", "--quiet")
    assert_one_line_refusal(code, out, err, "a folder")
    assert "is a folder, not a checkpoint file" in err
    assert not (tmp_path / "out").exists()
    run = _stopped(world, tmp_path / "run")  # its checkpoint.pt replaced by a folder: fit, resumed or not
    (run / CHECKPOINT_NAME).unlink()
    (run / CHECKPOINT_NAME).mkdir()
    before = _snapshot(run)
    for options in ((), ("--resume",), ("--overwrite",)):
        code, out, err = _fit(world, run, *options)
        assert_one_line_refusal(code, out, err, options)
        assert f"{run / CHECKPOINT_NAME}: not a regular file" in err, err
        assert _snapshot(run) == before and (run / CHECKPOINT_NAME).is_dir()


# --- temporary files, refusals that leave nothing -----------------------------------------------


def test_a_killed_writers_temporary_files_are_removed_on_start(world, tmp_path):
    run = _stopped(world, tmp_path / "run")
    stale = [run / f".{CHECKPOINT_NAME}.tmp-99999999", run / ".learning_curve.csv.tmp-99999999"]
    for path in stale:
        path.write_bytes(b"half a file")
    (run / "mine.txt").write_text("not the run's")
    code, _, err = _fit(world, run, "--resume")
    assert code == 0, err
    assert not any(p.exists() for p in stale) and (run / "mine.txt").is_file()


def test_a_fit_refused_while_it_reads_its_data_leaves_nothing(world, tmp_path):
    """A dataset with a flipped byte in its points, found when the first batch is read: the fresh run's
    log goes, and the folders it made."""
    dataset = tmp_path / "dataset"
    shutil.copytree(world["dataset"], dataset)
    points = max((p for p in dataset.rglob("*.parquet")), key=lambda p: p.stat().st_size)
    _flipped(points, points, points.stat().st_size // 2, 0)
    out = tmp_path / "new" / "run"
    code, out_text, err = run_main(main, "fit", world["config"], "--dataset", dataset, "-o", out, "--quiet")
    assert_one_line_refusal(code, out_text, err, "a damaged dataset")
    assert not (tmp_path / "new").exists()


def test_a_refused_eval_leaves_no_folder(world, tmp_path):
    """The smoke dataset's one clip is in the train split: `eval` on val is refused after the checkpoint
    is read, before anything is written."""
    code, out, err = run_main(main, "eval", world["whole"] / CHECKPOINT_NAME, "--dataset", world["dataset"], "-o",
                              tmp_path / "a" / "b", "--quiet")
    assert_one_line_refusal(code, out, err, "eval on no val clips")
    assert "no clips in the 'val' split" in err and not (tmp_path / "a").exists()


@pytest.mark.parametrize("command", ["fit", "eval", "detect"])
def test_an_output_inside_the_dataset_it_reads_is_refused(world, tmp_path, command):
    dataset = tmp_path / "dataset"
    shutil.copytree(world["dataset"], dataset)
    before = _snapshot(dataset)
    first = world["config"] if command == "fit" else world["whole"] / CHECKPOINT_NAME
    split = [] if command == "fit" else ["--split", "all"]  # the smoke dataset's one clip is a train clip
    for out in (dataset, dataset / "sub", dataset / "." / "sub" / ".." / "x"):
        code, out_text, err = run_main(main, command, first, "--dataset", dataset, "-o", out, "--quiet", *split)
        assert_one_line_refusal(code, out_text, err, (command, out))
        assert "inside the dataset it reads" in err
    assert _snapshot(dataset) == before and not (dataset / "sub").exists()


# --- no process left ----------------------------------------------------------------------------


def _progressed(process: subprocess.Popen, run: Path, saved: int) -> bool:
    """Whether the fit's two loader workers are up and it has saved a checkpoint past iteration `saved`."""
    assert process.poll() is None, process.stderr.read().decode()
    checkpoint = run / CHECKPOINT_NAME
    return len(_session(process.pid)) >= 3 and checkpoint.is_file() and load_checkpoint(checkpoint).iteration > saved


def test_kill_and_resume_cycles_of_fit_with_workers_leave_no_process(world, tmp_path):
    """KILL_CYCLES times: `fit --workers 2` runs until its loader workers are up and it has saved a new
    checkpoint, then only its main process is SIGKILLed; within GONE_S nothing of it is left (the workers
    die with it), and the next cycle resumes."""
    run = tmp_path / "run"
    longer = tmp_path / "longer.yaml"
    raw = yaml.safe_load(world["config"].read_text())
    raw["train"]["iterations"] = 100_000
    longer.write_text(yaml.safe_dump(raw))
    saved = 0
    for cycle in range(KILL_CYCLES):
        process = _train_process({**world, "config": longer}, run, "--workers", 2, *(["--resume"] if cycle else []))
        _wait(functools.partial(_progressed, process, run, saved), 180, f"cycle {cycle}: workers and a new checkpoint")
        assert _left_after(process) == [], f"cycle {cycle}"
        saved = load_checkpoint(run / CHECKPOINT_NAME).iteration
    assert saved >= KILL_CYCLES


def test_a_killed_study_takes_its_simgen_generate_with_it(tmp_path):
    """`study` of a scenario whose dataset is missing runs `simgen generate` (50 smoke clips, minutes of
    work; its progress on the study's stderr, a file here); SIGKILL the study alone once the generate runs:
    the generate goes too, within GONE_S."""
    scenario = yaml.safe_load(SMOKE.read_text())
    scenario.update(name="smoke_long", dataset={"clips": 50})
    (tmp_path / "long.yaml").write_text(yaml.safe_dump(scenario))
    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "late.yaml").write_text(yaml.safe_dump(tiny_config("late", iterations=1).model_dump(mode="json")))
    command = [sys.executable, "-m", "train.cli", "study", str(tmp_path / "long.yaml"), "-o", str(tmp_path / "out"),
               "--datasets", str(tmp_path / "datasets"), "--configs", str(configs), "--device", "cpu"]
    with open(tmp_path / "study.log", "w") as log:
        study = subprocess.Popen(command, cwd=ROOT, stdout=log, stderr=log, start_new_session=True)

    def generating() -> bool:
        assert study.poll() is None, (tmp_path / "study.log").read_text()
        return any(" generate " in line for _, line in _session(study.pid))

    _wait(generating, 120, "the study's simgen generate")
    assert _left_after(study) == []
