"""`simgen --help` and `simgen validate` start without the heavy libraries (Open3D, trimesh, torch,
the engine, numba): they are imported only by the commands that use them."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.support import ROOT
from tests.support.processes import HEAVY, imported_heavy


@pytest.mark.parametrize(
    "arguments", [("--help",), ("generate", "--help"), ("pattern", "--help"), ("validate", "scenarios/smoke.yaml")]
)
def test_help_and_validate_import_no_heavy_library(arguments):
    imported = imported_heavy(*arguments)
    assert imported & (set(HEAVY) | {"numba"}) == set()


def test_reading_datasets_and_training_need_no_writer_libraries():
    """In a Python without mcap, mcap-ros2-support, rosbags, laspy, Open3D, trimesh or numba (a training
    machine), `simgen.datasets` and `train.cli` import: the bag writer and reader import theirs when
    used, the Risley pattern compiles its loops when directions are first asked for."""
    blocked = ("mcap", "mcap_ros2", "rosbags", "laspy", "open3d", "trimesh", "numba")
    probe = (
        "import importlib.abc, sys\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        f"    def find_spec(self, name, path, target=None):\n"
        f"        if name.split('.')[0] in {blocked!r}: raise ImportError('blocked: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import simgen.datasets, train.cli, train.study.run\n"
        "print('imported')\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0 and result.stdout == "imported\n", result.stderr[-2000:]
