"""A check's verdict: what was measured, against which limit, pass or fail (or not applicable)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass


@dataclass(frozen=True)
class Check:
    subject: str  # what was checked, e.g. "mid40-risley head 0" or "dataset"
    name: str  # e.g. "coverage, 0.2 deg cells"
    measured: str  # the measured value, with units and where it is worst
    limit: str  # the tolerance, with units
    passed: bool | None  # None: not applicable here (`measured` says why)

    @property
    def verdict(self) -> str:
        return {True: "pass", False: "FAIL", None: "n/a"}[self.passed]


def plural(count: int, noun: str) -> str:
    """`1 point`, `2 points`."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def exit_code(checks: Iterable[Check]) -> int:
    """0 when no check failed, 1 otherwise."""
    return 1 if any(c.passed is False for c in checks) else 0


def summary(checks: list[Check]) -> str:
    """One line: how many checks passed, failed and did not apply."""
    counts = {verdict: sum(c.verdict == verdict for c in checks) for verdict in ("pass", "FAIL", "n/a")}
    overall = "FAIL" if counts["FAIL"] else "PASS"
    return f"{overall}: {counts['pass']} passed, {counts['FAIL']} failed, {counts['n/a']} not applicable"
