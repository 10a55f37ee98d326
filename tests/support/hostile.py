"""Shared by the hostile-input tests: a CLI's `main` in this process, a command as a real process with
its own peak memory and CPU time, and the refusal every case must be (exit 2, one line, no traceback)."""

from __future__ import annotations

import contextlib
import io
import json
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis.strategies import SearchStrategy

from tests.support import ROOT

SETTINGS = {"deadline": None, "suppress_health_check": list(HealthCheck), "database": None}
MAX_SECONDS_EACH = 2.0  # CPU seconds of this process per refusal; a real process adds its start-up
MAX_GROWTH_BYTES = 256 << 20  # peak memory of this process, over all the generated cases


def run_main(main: Callable[[list[str]], int], *arguments) -> tuple[int, str, str]:
    """`main(ARGUMENTS)` in this process: exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in arguments])
        except SystemExit as exit_:  # argparse
            code = exit_.code
    return code, out.getvalue(), err.getvalue()


def assert_one_line_refusal(code: int, out: str, err: str, what: object) -> None:
    assert code == 2, (what, code, out, err)
    assert out == "" and err.endswith("\n") and err.count("\n") == 1, (what, out, err)
    assert "Traceback" not in err, (what, err)


def refuse_generated(
    strategy: SearchStrategy,
    examples: int,
    prepare: Callable[[object], tuple[str, object, Callable[[], tuple[int, str, str]]]],
    what: str,
) -> dict[str, int]:
    """Draw `examples` cases from `strategy`; `prepare(case)` gives (kind, context for a failure, the refusal to
    run -> exit code, stdout, stderr). Each must be refused in one line, within MAX_SECONDS_EACH CPU seconds of
    this process (what the refusal costs, whatever the machine's load), and all of them within
    MAX_GROWTH_BYTES of peak memory. Returns the cases per kind."""
    kinds: dict[str, int] = {}
    slowest = [0.0]
    peak = peak_bytes()

    @settings(max_examples=examples, **SETTINGS)
    @given(strategy)
    def check(case):
        kind, context, refusal = prepare(case)
        started = time.process_time()
        code, out, err = refusal()
        slowest[0] = max(slowest[0], time.process_time() - started)
        assert_one_line_refusal(code, out, err, (kind, context))
        kinds[kind] = kinds.get(kind, 0) + 1

    check()
    print(f"{sum(kinds.values())} {what} in {len(kinds)} kinds refused; slowest {slowest[0]:.2f} CPU s; "
          f"peak memory +{(peak_bytes() - peak) / 2**20:.0f} MiB")
    assert slowest[0] < MAX_SECONDS_EACH
    assert peak_bytes() - peak < MAX_GROWTH_BYTES
    return kinds


def peak_bytes() -> int:
    """This process's peak resident memory so far."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def measured_process(module: str, *arguments) -> tuple[int, str, str, int, float]:
    """`python -m MODULE ARGUMENTS` as a real process: exit code, stdout, stderr, peak resident bytes, CPU
    seconds (user + system: what the process itself spent, whatever else the machine runs meanwhile)."""
    with tempfile.TemporaryDirectory() as scratch:
        report = Path(scratch) / "usage"
        command = [sys.executable, "-m", module, *map(str, arguments)]
        # the launcher keeps this (by now large) test process's RSS out of the child's peak
        launcher = [sys.executable, str(ROOT / "benchmarks" / "measure_child.py"), str(report)]
        done = subprocess.run([*launcher, *command], cwd=ROOT, capture_output=True, text=True)
        usage = json.loads(report.read_text())
        return usage["exit_code"], done.stdout, done.stderr, usage["peak_bytes"], usage["cpu_s"]
