"""Real processes the tests start: the `simgen` CLI, a local Ray cluster, a probe of what a command imports."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import subprocess
import sys

from tests.support import ROOT

HEAVY = ("open3d", "trimesh", "torch", "gfootball", "gfootball_engine")
PROBE = """
import sys
from simgen.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
import json
loaded = {name.split(".")[0] for name in sys.modules}
print("IMPORTED " + json.dumps(sorted(loaded & set(%r | {"numba"}))), file=sys.stderr)
"""


def run_simgen(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the `simgen` CLI in a subprocess, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "simgen.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
    )


def imported_heavy(*arguments: str) -> set[str]:
    """Which of HEAVY and numba a `simgen` command line imports."""
    result = subprocess.run(
        [sys.executable, "-c", PROBE % (set(HEAVY),), *arguments], capture_output=True, text=True, cwd=ROOT
    )
    line = next(line for line in result.stderr.splitlines() if line.startswith("IMPORTED "))
    return set(json.loads(line.removeprefix("IMPORTED ")))


@contextlib.contextmanager
def local_ray_cluster():
    """A real Ray cluster on this machine (`ray start --head` on a free loopback port); yields its address."""
    ray = str(ROOT / ".venv" / "bin" / "ray")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    subprocess.run(
        [
            ray,
            "start",
            "--head",
            f"--port={port}",
            "--node-ip-address=127.0.0.1",
            "--num-cpus=2",
            "--include-dashboard=false",
            "--disable-usage-stats",
        ],
        check=True,
        capture_output=True,
        env=env,
        timeout=180,
    )
    try:
        yield f"127.0.0.1:{port}"
    finally:
        subprocess.run([ray, "stop", "--force"], capture_output=True, env=env, timeout=120)
