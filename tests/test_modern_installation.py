"""scenarios/modern_mid360.yaml: four Mid-360 replaying Livox's table generate, verify and view, and
every point carries the laser that fired it."""

from __future__ import annotations

import numpy as np

import simgen.datasets
from tests.support.processes import run_simgen


def test_four_mid360_generate_verify_and_view_with_each_points_laser(tmp_path):
    out = tmp_path / "modern"
    result = run_simgen("generate", "scenarios/modern_mid360.yaml", "-o", out, "--frames", "5", "--workers", "1")
    assert result.returncode == 0, result.stderr
    assert "PatternLoopWarning" not in result.stderr and "loops past" not in result.stderr
    verify = run_simgen("verify", out)
    assert verify.returncode == 0 and verify.stdout.startswith(f"{out}: ok"), verify.stdout + verify.stderr
    data = simgen.datasets.open(out)
    frame = data.frame(data.clips[0], 4)
    assert sorted(np.unique(frame.sensor)) == [0, 1, 2, 3] and sorted(np.unique(frame.line)) == [0, 1, 2, 3]
    assert frame.num_points.sum() > 0  # the players are seen
    view = run_simgen("view", out, "--frames", "0:5", "-o", tmp_path / "view", "--export-frame", "2")
    assert view.returncode == 0, view.stderr
    assert (tmp_path / "view" / "clip_0000.mp4").stat().st_size > 0
