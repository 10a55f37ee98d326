"""Reliability: bad input is one line and exit 2 and leaves nothing; crashes cost minutes, never data.

The figures in docs/reliability.md come from the constants and counts asserted here.
"""

from __future__ import annotations

import json
import math
import os
import random
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import simgen.datasets as datasets
from simgen.errors import UserError
from simgen.scenario import parse_scenario
from tests.support import ROOT
from tests.support.processes import local_ray_cluster, run_simgen

SMOKE = ROOT / "scenarios" / "smoke.yaml"
KILL_ROUNDS = 6  # generation runs killed at a random moment (each then resumed, maybe killed again)
MAX_KILLS_PER_ROUND = 3  # then the resumed run is left to finish
GENERATED_CONFIGS = 600  # hypothesis examples of mutated scenarios
SMALL = ("--frames", "4", "--clips", "2")


def _write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.write_text(text)
    return path


def _bad_inputs(tmp: Path) -> list[tuple[str, list]]:
    """(what is wrong, simgen arguments) — each must fail with one line and exit 2."""
    out = tmp / "out"
    dataset = tmp / "existing"
    dataset.mkdir()
    (dataset / "manifest.json").write_text("{}")
    count = iter(range(1000))

    def scenario(text: str) -> Path:
        return _write(tmp, f"scenario{next(count)}.yaml", "name: t\n" + text)

    return [
        ("malformed YAML", ["validate", _write(tmp, "broken.yaml", "name: t\nmotion: [1, 2\n")]),
        ("YAML that is not a mapping", ["validate", _write(tmp, "list.yaml", "- a\n- b\n")]),
        ("unknown top-level key", ["validate", scenario("sensorz: []\n")]),
        ("unknown nested key", ["validate", scenario("motion:\n  frmaes: 3\n")]),
        ("wrong type", ["validate", scenario("seed: seven\n")]),
        ("negative frame count", ["validate", scenario("motion:\n  frames: -10\n")]),
        ("density 0", ["validate", scenario("scan:\n  density: 0\n")]),
        ("negative density", ["validate", scenario("scan:\n  density: -2\n")]),
        ("negative range noise", ["validate", scenario("noise:\n  range_sigma_m: -0.01\n")]),
        ("negative dropout", ["validate", scenario("noise:\n  dropout: -0.1\n")]),
        (
            "field of view over 180 degrees",
            ["validate", scenario("custom_sensors:\n  - {name: w, heads: [{like: mid40-rose, fov_deg: 190}]}\n")],
        ),
        ("frame rate 0", ["validate", scenario("scan:\n  frame_rate_hz: 0\n")]),
        ("unknown sensor preset", ["validate", scenario("sensors:\n  - {preset: mid999}\n")]),
        ("unknown pattern", ["validate", scenario("custom_sensors:\n  - {name: w, heads: [{pattern: spiral}]}\n")]),
        ("unknown engine level", ["validate", scenario("motion:\n  level: no_such_level\n")]),
        ("more frames than the motion", ["validate", scenario("scan:\n  frames: 500\n")]),
        ("missing scenario file", ["validate", tmp / "absent.yaml"]),
        ("a directory as scenario", ["validate", tmp]),
        ("undecodable scenario file", ["validate", _binary(tmp)]),
        ("unknown pattern preset", ["pattern", "mid999", "--seconds", "0.1", "-o", out / "p.npz"]),
        ("negative seconds", ["pattern", "mid40-rose", "--seconds", "-1", "-o", tmp / "p.npz"]),
        ("density 0 on the command line", ["generate", SMOKE, "-o", out, "--density", "0"]),
        ("unknown dataset format", ["generate", SMOKE, "-o", out, "--format", "las"]),
        ("zero workers", ["generate", SMOKE, "-o", out, "--workers", "0"]),
        ("existing dataset without --overwrite", ["generate", SMOKE, "-o", dataset]),
        ("capture into a missing directory", ["capture", SMOKE, "-o", tmp / "no" / "m.parquet"]),
        ("capture to a non-Parquet name", ["capture", SMOKE, "-o", tmp / "m.csv"]),
        ("no such sub-command", ["fly", SMOKE]),
        ("a missing required option", ["generate", SMOKE]),
    ]


def _binary(tmp: Path) -> Path:
    path = tmp / "binary.yaml"
    path.write_bytes(b"\xff\xfe\x00name")
    return path


def _files(directory: Path) -> set[Path]:
    return set(directory.rglob("*"))


def test_bad_input_table(tmp_path):
    cases = _bad_inputs(tmp_path)
    before = _files(tmp_path)
    for what, arguments in cases:
        result = run_simgen(*arguments)
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2, (what, result.stderr)
        assert len(lines) == 1 and "Traceback" not in result.stderr, (what, result.stderr)
        assert _files(tmp_path) == before, (what, _files(tmp_path) - before)
    assert len(cases) == 29


def test_output_outside_the_allowed_roots(tmp_path):
    allowed = tmp_path / "allowed"
    allowed.mkdir()
    env = {**os.environ, "SIMGEN_OUTPUT_ROOTS": str(allowed)}
    for arguments in (
        ["generate", SMOKE, "-o", tmp_path / "elsewhere"],
        ["capture", SMOKE, "-o", tmp_path / "m.parquet"],
        ["pattern", "mid40-rose", "--seconds", "0.01", "-o", tmp_path / "p.npz"],
    ):
        result = subprocess.run(
            [sys.executable, "-m", "simgen.cli", *map(str, arguments)],
            capture_output=True,
            text=True,
            env=env,
            cwd=ROOT,
        )
        assert result.returncode == 2 and "outside the allowed output roots" in result.stderr
        assert result.stderr.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["allowed"]
    ok = subprocess.run(
        [
            sys.executable,
            "-m",
            "simgen.cli",
            "pattern",
            "mid40-rose",
            "--seconds",
            "0.01",
            "-o",
            str(allowed / "p.npz"),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert ok.returncode == 0, ok.stderr


VALID = yaml.safe_load(SMOKE.read_text())
SECTIONS = {
    "motion": ["level", "frames", "capture_hz", "skip_s", "left_difficulty"],
    "scan": ["frame_rate_hz", "density", "sweeps_per_frame", "frames"],
    "noise": ["range_sigma_m", "angle_sigma_deg", "subrays", "min_range_m", "dropout", "divergence_deg"],
    "scene": ["goals", "surroundings", "net_transmission"],
    "dataset": ["clips", "format"],
}
BAD_VALUES = st.one_of(
    st.integers(-10**9, 0),
    st.floats(allow_nan=True, allow_infinity=True).filter(lambda x: not 0 < x < 1),
    st.text(max_size=6),
    st.none(),
    st.lists(st.integers(), max_size=3),
    st.just({"nested": 1}),
)


@st.composite
def mutated_scenarios(draw):
    data = json.loads(json.dumps(VALID))
    kind = draw(st.sampled_from(["value", "unknown key", "unknown section", "drop name"]))
    section = draw(st.sampled_from(sorted(SECTIONS)))
    if kind == "value":
        data.setdefault(section, {})[draw(st.sampled_from(SECTIONS[section]))] = draw(BAD_VALUES)
    elif kind == "unknown key":
        data.setdefault(section, {})[
            draw(st.text(min_size=1, max_size=8).filter(lambda k: k not in SECTIONS[section]))
        ] = 1
    elif kind == "unknown section":
        data[draw(st.text(min_size=1, max_size=8).filter(lambda k: k not in VALID and k not in SECTIONS))] = {}
    else:
        del data["name"]
    return data


def test_generated_bad_configs_are_one_line_errors():
    """Each mutated scenario is a one-line error or really in range; most of them are errors."""
    outcomes = {"rejected": 0, "accepted": 0}  # counted by this test's own examples

    @settings(max_examples=GENERATED_CONFIGS, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(mutated_scenarios())
    def check(data):
        try:
            scenario = parse_scenario(data, "generated.yaml")
        except UserError as error:
            outcomes["rejected"] += 1
            message = str(error)
            assert "\n" not in message and message.startswith("generated.yaml: ")
        else:  # a mutation that happens to be valid must really be within range
            outcomes["accepted"] += 1
            assert scenario.scan.density > 0 and scenario.scan.frame_rate_hz > 0 and scenario.noise.range_sigma_m >= 0

    check()
    assert sum(outcomes.values()) >= GENERATED_CONFIGS * 0.9
    assert outcomes["rejected"] >= 0.8 * sum(outcomes.values())


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _group_cpu_s(group: int) -> float:
    """CPU seconds spent so far by process group `group`: its live members and the children they reaped."""
    total = 0
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == group:  # fields from the state on: pgrp is the 3rd, utime .. cstime the 12th-15th
            total += sum(int(v) for v in fields[11:15])
    return total / os.sysconf("SC_CLK_TCK")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run and the CPU seconds it took (its processes', whatever else the machine runs)."""
    out = tmp_path_factory.mktemp("reference") / "d"
    before = _children_cpu_s()
    result = run_simgen("generate", SMOKE, "-o", out, *SMALL)
    assert result.returncode == 0, result.stderr
    return out, _children_cpu_s() - before


def _shas(root: Path) -> dict[str, str]:
    return {f["path"]: f["sha256"] for f in json.loads((root / "manifest.json").read_text())["files"]}


def _assert_no_partial_files(root: Path, reference_shas: dict[str, str], reference_root: Path) -> None:
    """Every file under its final name is complete: identical to the uninterrupted run's."""
    from simgen.datasets.records import sha256_file

    for path in root.rglob("*"):
        relative = path.relative_to(root).as_posix()
        if path.is_dir() or relative.startswith(".simgen") or ".tmp-" in path.name:
            continue
        if relative in reference_shas:
            assert sha256_file(path) == reference_shas[relative], relative
        else:
            assert path.read_bytes() == (reference_root / relative).read_bytes(), relative


@pytest.mark.engine
def test_sigkill_at_random_moments_then_resume(reference, tmp_path):
    """Each run is killed once its processes have spent a random 10-80 % of the uninterrupted run's CPU
    seconds (a moment in the work done, not in wall time, which a loaded machine stretches)."""
    reference, cpu_s = reference
    rng = random.Random(1234)
    expected = _shas(reference)
    kills = 0
    for round_ in range(KILL_ROUNDS):
        out = tmp_path / f"run{round_}"
        command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out), *SMALL]
        resume, attempts = False, 0
        # until finished and cleaned up: a run killed after its manifest is resumed too
        while not (out / "manifest.json").exists() or (out / ".simgen" / "scenario.json").exists():
            process = subprocess.Popen(command + (["--resume"] if resume else []), cwd=ROOT, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.PIPE, process_group=0)
            target_s = rng.uniform(0.1, 0.8) * cpu_s if attempts < MAX_KILLS_PER_ROUND else math.inf
            attempts += 1
            while process.poll() is None and _group_cpu_s(process.pid) < target_s:
                time.sleep(0.005)
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
                kills += 1
            else:
                assert process.returncode == 0, process.stderr.read().decode()[-1000:]
            _assert_no_partial_files(out, expected, reference)
            resume = True
        assert _shas(out) == expected
        assert not (out / ".simgen").exists() or not list((out / ".simgen").glob("clips/*"))
    print(f"{kills} kills in {KILL_ROUNDS} runs, each resumed to the uninterrupted run's manifest")
    assert kills >= KILL_ROUNDS, kills


@pytest.mark.engine
def test_ray_worker_killed_mid_task_is_retried(reference, tmp_path):
    with local_ray_cluster() as address:
        out = tmp_path / "ray"
        command = [sys.executable, "-m", "simgen.cli", "generate", str(SMOKE), "-o", str(out), *SMALL,
                   "--executor", "ray", "--address", address]
        driver = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        killed = None
        deadline = time.time() + 180
        while killed is None and time.time() < deadline and driver.poll() is None:
            tasks = subprocess.run(
                ["pgrep", "-f", "ray::run_job_reporting"], capture_output=True, text=True
            ).stdout.split()
            if tasks:
                time.sleep(0.5)
                os.kill(int(tasks[0]), signal.SIGKILL)
                killed = int(tasks[0])
            time.sleep(0.05)
        _, stderr = driver.communicate(timeout=600)
    assert killed is not None, "no Ray task was seen running"
    assert driver.returncode == 0, stderr[-2000:]
    assert _shas(out) == _shas(reference[0])


@pytest.mark.engine
@pytest.mark.parametrize("fmt", ["parquet", "kitti", "openpcdet"])
def test_every_flipped_file_is_detected(tmp_path, fmt):
    out = tmp_path / fmt
    assert run_simgen("generate", SMOKE, "-o", out, "--frames", "3", "--format", fmt).returncode == 0
    files = [f["path"] for f in json.loads((out / "manifest.json").read_text())["files"]]
    detected = read_by_reader = 0
    for relative in files:
        path = out / relative
        original = path.read_bytes()
        position = len(original) // 2
        if original:  # flip the middle byte; an empty file gets one instead
            path.write_bytes(original[:position] + bytes([original[position] ^ 0xFF]) + original[position + 1 :])
        else:
            path.write_bytes(b"\n")
        try:
            try:  # the reader checks a file's sha256 when it first reads it
                dataset = datasets.open(out)
                for clip in dataset.clips:
                    for index in range(dataset.num_frames(clip)):
                        dataset.frame(clip, index)
            except UserError as error:
                assert relative.split("/")[-1] in str(error)
                read_by_reader += 1
            verify = run_simgen("verify", out)
            assert verify.returncode == 1 and relative in verify.stdout + verify.stderr
            detected += 1
        finally:
            path.write_bytes(original)
    assert detected == len(files) > 0
    print(
        f"{fmt}: {detected} of {len(files)} flipped files detected by verify, {read_by_reader} also by reading frames"
    )
    # all but the tables frames never read, and OpenPCDet's MMDetection3D infos, which simgen does not read
    assert read_by_reader >= len(files) - 2 - (fmt != "parquet") - 2 * (fmt == "openpcdet")


def test_no_pickle_in_simgen():
    """Datasets never hold pickles and checkpoints load without them: no pickle (de)serialisation,
    no allow_pickle=True, and every torch.load with weights_only=True, anywhere in our packages."""
    import re

    offenders = []
    for package in ("simgen", "train", "scan_patterns"):
        for path in (ROOT / package).rglob("*.py"):
            text = path.read_text()
            unsafe = re.search(r"pickle\.(loads?|dumps?)\(|allow_pickle=True|weights_only=False", text)
            loads = re.findall(r"torch\.load\(([^)]*)\)", text)
            if unsafe or any("weights_only=True" not in call for call in loads):
                offenders.append(path.relative_to(ROOT).as_posix())
    assert offenders == []
