"""Shared test fixtures: the committed motion clip and a way to run the CLI."""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"
MOTION_FIXTURE = FIXTURES / "motion_smoke.parquet"


def run_simgen(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the `simgen` CLI in a subprocess, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "simgen.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
    )


@pytest.fixture(scope="session")
def motion_clip():
    """The committed clip captured from the real engine by `simgen capture` (see tests/fixtures/README.md)."""
    from simgen.motion.clip_io import read_clip

    return read_clip(MOTION_FIXTURE)


@contextlib.contextmanager
def local_ray_cluster():
    """A real Ray cluster on this machine (`ray start --head` on a free loopback port); yields its address."""
    ray = str(ROOT / ".venv" / "bin" / "ray")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    subprocess.run(
        [ray, "start", "--head", f"--port={port}", "--node-ip-address=127.0.0.1", "--num-cpus=2", "--include-dashboard=false", "--disable-usage-stats"],
        check=True, capture_output=True, env=env, timeout=180,
    )
    try:
        yield f"127.0.0.1:{port}"
    finally:
        subprocess.run([ray, "stop", "--force"], capture_output=True, env=env, timeout=120)
