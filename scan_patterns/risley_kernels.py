"""`scan_patterns.risley.directions`' compiled loops (numba): imported when directions are first asked for,
so that reading presets and scenarios (`import simgen.scenario`, `train.cli`) needs no numba."""

from __future__ import annotations

import numba
import numpy as np

ANCHOR = 64  # shots between exact evaluations of the prism angles on a shot clock


@numba.njit(cache=True)
def _angles(t, turns):
    """cos, sin of both prisms' angles at time t (s), phases reduced to one turn in float64."""
    angle1 = 2.0 * np.pi * ((turns[0, 0] * t + turns[0, 1]) % 1.0)
    angle2 = 2.0 * np.pi * ((turns[1, 0] * t + turns[1, 1]) % 1.0)
    return np.cos(angle1), np.sin(angle1), np.cos(angle2), np.sin(angle2)


@numba.njit(cache=True)
def _emit(c1, s1, c2, s2, A, B, C, D, n, out, k):
    """The direction for prism angles (c1, s1), (c2, s2) into out[k]."""
    eta = 1.0 / n
    cos_in = A * C + B * D * (c1 * c2 + s1 * s2)
    k_out = np.sqrt(1.0 - eta * eta + eta * eta * cos_in * cos_in) - eta * cos_in
    u = eta * A + k_out * C
    lateral = n * D * k_out
    out[k, 0] = np.sqrt(1.0 - n * n + n * n * u * u)
    out[k, 1] = B * c1 + lateral * c2
    out[k, 2] = B * s1 + lateral * s2


@numba.njit(cache=True)
def trace_times(t_s, A, B, C, D, n, turns, out):
    """`directions` at arbitrary times: every angle exact."""
    for k in range(len(t_s)):
        c1, s1, c2, s2 = _angles(t_s[k], turns)
        _emit(c1, s1, c2, s2, A, B, C, D, n, out, k)


@numba.njit(cache=True)
def trace_clock(first, count, rate_hz, A, B, C, D, n, turns, out):
    """`directions` of shots first .. first + count - 1 of a clock at rate_hz: exact angles at every
    index divisible by ANCHOR (starting before `first` if need be), one clock step of rotation between."""
    r1, r2 = 2.0 * np.pi * turns[0, 0] / rate_hz, 2.0 * np.pi * turns[1, 0] / rate_hz
    rc1, rs1, rc2, rs2 = np.cos(r1), np.sin(r1), np.cos(r2), np.sin(r2)
    c1 = s1 = c2 = s2 = 0.0
    for shot in range(first - first % ANCHOR, first + count):
        if shot % ANCHOR == 0:
            c1, s1, c2, s2 = _angles(shot / rate_hz, turns)
        else:
            c1, s1 = c1 * rc1 - s1 * rs1, s1 * rc1 + c1 * rs1
            c2, s2 = c2 * rc2 - s2 * rs2, s2 * rc2 + c2 * rs2
        if shot >= first:
            _emit(c1, s1, c2, s2, A, B, C, D, n, out, shot - first)
