"""`scan_patterns.risley.directions`' compiled loops (numba): imported when directions are first asked for,
so that reading presets and scenarios (`import simgen.scenario`, `train.cli`) needs no numba."""

from __future__ import annotations

import numba
import numpy as np

ANCHOR = 64  # rounds of the lasers between exact evaluations of the prism angles on a shot clock


@numba.njit(cache=True)
def _angles(t, turns, cos_t, sin_t):
    """cos, sin of every prism's angle at time t (s), phases reduced to one turn in float64."""
    for p in range(len(turns)):
        angle = 2.0 * np.pi * ((turns[p, 0] * t + turns[p, 1]) % 1.0)
        cos_t[p] = np.cos(angle)
        sin_t[p] = np.sin(angle)


@numba.njit(cache=True)
def _face(sx, sy, sz, nx, ny, nz, eta):
    """Snell's law at one face (unit normal n, s . n > 0), eta = n_before / n_after."""
    cos_in = sx * nx + sy * ny + sz * nz
    k = np.sqrt(1.0 - eta * eta * (1.0 - cos_in * cos_in)) - eta * cos_in
    return eta * sx + k * nx, eta * sy + k * ny, eta * sz + k * nz


@numba.njit(cache=True)
def _emit(beam, cos_t, sin_t, cos_a, sin_a, index, wedged_first, out, k):
    """Beam (3,) through every prism at angles (cos_t, sin_t) into out[k]."""
    sx, sy, sz = beam[0], beam[1], beam[2]
    for p in range(len(cos_a)):
        nx, ny, nz = cos_a[p], sin_a[p] * cos_t[p], sin_a[p] * sin_t[p]
        n = index[p]
        if wedged_first[p]:
            sx, sy, sz = _face(sx, sy, sz, nx, ny, nz, 1.0 / n)
            sx, sy, sz = _face(sx, sy, sz, 1.0, 0.0, 0.0, n)
        else:
            sx, sy, sz = _face(sx, sy, sz, 1.0, 0.0, 0.0, 1.0 / n)
            sx, sy, sz = _face(sx, sy, sz, nx, ny, nz, n)
    out[k, 0] = sx
    out[k, 1] = sy
    out[k, 2] = sz


@numba.njit(cache=True)
def trace_times(t_s, line, beams, cos_a, sin_a, index, wedged_first, turns, out):
    """`directions` at arbitrary times: every angle exact."""
    cos_t, sin_t = np.empty(len(turns)), np.empty(len(turns))
    for k in range(len(t_s)):
        _angles(t_s[k], turns, cos_t, sin_t)
        _emit(beams[line[k]], cos_t, sin_t, cos_a, sin_a, index, wedged_first, out, k)


@numba.njit(cache=True)
def trace_clock(first, count, rate_hz, beams, cos_a, sin_a, index, wedged_first, turns, out):
    """`directions` of shots first .. first + count - 1 of a clock at rate_hz, L lasers taking turns:
    round r (shots L r + 1 .. L r + L) at the time of its first shot, exact angles at every round
    divisible by ANCHOR (starting before the first round if need be), a fixed rotation between."""
    lasers = len(beams)
    prisms = len(turns)
    step_c, step_s = np.empty(prisms), np.empty(prisms)
    for p in range(prisms):
        step = 2.0 * np.pi * turns[p, 0] * lasers / rate_hz
        step_c[p], step_s[p] = np.cos(step), np.sin(step)
    cos_t, sin_t = np.zeros(prisms), np.zeros(prisms)
    first_round = (first - 1) // lasers
    last_round = (first + count - 2) // lasers
    for r in range(first_round - first_round % ANCHOR, last_round + 1):
        if r % ANCHOR == 0:
            _angles((lasers * r + 1) / rate_hz, turns, cos_t, sin_t)
        else:
            for p in range(prisms):
                c, s = cos_t[p], sin_t[p]
                cos_t[p] = c * step_c[p] - s * step_s[p]
                sin_t[p] = s * step_c[p] + c * step_s[p]
        if r >= first_round:
            for laser in range(lasers):
                k = lasers * r + 1 + laser - first
                if 0 <= k < count:
                    _emit(beams[laser], cos_t, sin_t, cos_a, sin_a, index, wedged_first, out, k)
