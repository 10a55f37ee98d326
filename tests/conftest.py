"""Shared test fixtures: the committed motion clip and a way to run the CLI."""

from __future__ import annotations

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
    from simgen.motion_io import read_clip

    return read_clip(MOTION_FIXTURE)
