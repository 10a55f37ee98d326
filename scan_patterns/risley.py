"""`risley`: the Livox Mid-40 optics, two wedge prisms rotating in opposite directions.

The beam leaves the laser along the head's x axis (the boresight) and crosses, in order:
prism 1's flat face, prism 1's wedged face, prism 2's wedged face, prism 2's flat face (the
wedged faces face each other; flat faces are normal to x). Snell's law in vector form is applied
at each of the four faces. A wedged face's normal is tilted by the wedge angle from x towards the
prism's angle theta, measured in the head's y-z plane from +y towards +z; theta = 2 pi rpm / 60 t +
phase. Identical prisms at the same angle make a parallel plate (the beam leaves on the
boresight); at opposite angles their deviations add up to the edge of the field of view.

`MID40` holds the parameters fitted to Livox's official Mid-40 file by `scan_patterns.fit_risley`
(max per-shot error 1.1e-5 deg with `directions_exact` and with the compiled, float32 `directions`).
Both prisms come out as the same glass and wedge, and the rates as whole rpm; with 4664 and
-7294 rpm (gcd 2 rpm) the pattern repeats only every 30 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scan_patterns.timebase import cycles


@dataclass(frozen=True)
class RisleyParams:
    """A Risley pair: prism 1 is the one the laser meets first."""

    wedge_deg: tuple[float, float]  # wedge angle of prism 1, prism 2
    index: float  # refractive index of both prisms (at the laser's wavelength)
    rpm: tuple[float, float]  # rotation rates, revolutions per minute, + = from +y towards +z
    phase_deg: tuple[float, float]  # prism angles theta at t = 0

    def __post_init__(self) -> None:
        if not self.index > 1.0:
            raise ValueError(f"risley: refractive index must exceed 1, got {self.index}")
        for wedge in self.wedge_deg:
            if not 0.0 < wedge < 45.0:
                raise ValueError(f"risley: wedge angle must be in (0, 45) degrees, got {wedge}")


# Fitted to mid40_official_4s.npz by `python -m scan_patterns.fit_risley`, which returns these
# round values to within 3e-7 deg (wedges, phases), 1e-8 (index) and 1e-8 rpm; max error 1.06e-5 deg.
MID40 = RisleyParams(wedge_deg=(18.0, 18.0), index=1.5089, rpm=(-7294.0, 4664.0), phase_deg=(180.0, 0.0))


def _refract(s, normal, eta):
    """Snell's law, vector form: direction `s` crossing a face with unit `normal` (s . normal > 0).

    `eta` is n_before / n_after. Works on tuples of arrays (any dtype) or scalars, broadcasting.
    """
    sx, sy, sz = s
    nx, ny, nz = normal
    cos_in = sx * nx + sy * ny + sz * nz
    k = np.sqrt(1.0 - eta * eta * (1.0 - cos_in * cos_in)) - eta * cos_in
    return eta * sx + k * nx, eta * sy + k * ny, eta * sz + k * nz


def _refract_flat(s, eta):
    """`_refract` through a face normal to x (normal (1, 0, 0)), with fewer operations."""
    sx, sy, sz = s
    return np.sqrt(1.0 - eta * eta * (1.0 - sx * sx)), eta * sy, eta * sz


def _prism1_cone(params: RisleyParams) -> tuple[float, float]:
    """(x, lateral) of the beam out of prism 1 at theta1 = 0: at any theta1 it is that cone turned."""
    n, alpha1 = params.index, np.radians(params.wedge_deg[0])
    along, lateral, _ = _refract(_refract_flat((1.0, 0.0, 0.0), 1.0 / n), (np.cos(alpha1), np.sin(alpha1), 0.0), n)
    return float(along), float(lateral)


def trace(params: RisleyParams, cos1, sin1, cos2, sin2):
    """Exit direction (x, y, z) for prism angles given by their cosines and sines: the reference.

    Prism 1 meets the beam on the boresight, so its output is one direction turned about x by
    theta1: traced once at theta1 = 0, then rotated. Prism 2 is traced shot by shot.
    """
    n, alpha2 = params.index, np.radians(params.wedge_deg[1])
    along, lateral = _prism1_cone(params)
    s = (along, lateral * cos1, lateral * sin1)  # out of prism 1
    wedge2 = (np.cos(alpha2), np.sin(alpha2) * cos2, np.sin(alpha2) * sin2)
    s = _refract(s, wedge2, 1.0 / n)  # into prism 2 through its wedged face
    return _refract_flat(s, n)  # out of prism 2 through its flat face


def prism_angles(params: RisleyParams, t_s: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Prism angles theta1, theta2 (radians, in [0, 2 pi), float64) at times `t_s`."""
    return tuple(
        cycles(t_s, rpm / 60.0, np.radians(phase)) for rpm, phase in zip(params.rpm, params.phase_deg)
    )


def directions_exact(params: RisleyParams, t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3) float64 unit directions, head frame: the reference for fitting and tests."""
    th1, th2 = prism_angles(params, np.asarray(t_s, np.float64))
    return np.stack(trace(params, np.cos(th1), np.sin(th1), np.cos(th2), np.sin(th2)), axis=1)


def directions(
    params: RisleyParams, t_s: NDArray[np.float64], clock: tuple[int, float] | None = None
) -> NDArray[np.float32]:
    """(N, 3) float32 unit directions, head frame: `trace` in a compiled loop, fast.

    The same optics as `trace`, expanded for prism 1's cone (x A, lateral B) and prism 2's wedge
    (normal C along x, D across) with n eta = 1:
      cos_in = A C + B D cos(theta1 - theta2),  k = sqrt(1 - eta^2 + eta^2 cos_in^2) - eta cos_in
      x = sqrt(1 - n^2 + n^2 (eta A + k C)^2),  (y, z) = B (cos, sin) theta1 + n D k (cos, sin) theta2
    in float64, stored as float32 (within 1e-5 deg of `trace`). Phases are reduced to one turn in
    float64, so they stay exact at any time. With `clock` = (first shot index, shots per second), the
    times are a head's shot clock, t_s[i] = (first + i) / rate: the prism angles are taken exactly at
    every shot index divisible by `risley_kernels.ANCHOR` and advanced by a fixed rotation in between, so a shot's
    direction depends on its index alone, whatever window asks for it. Without, every angle is exact.
    """
    t_s = np.ascontiguousarray(t_s, np.float64)
    out = np.empty((len(t_s), 3), np.float32)
    A, B = _prism1_cone(params)
    alpha2 = np.radians(params.wedge_deg[1])
    turns = np.array([(rpm / 60.0, phase / 360.0) for rpm, phase in zip(params.rpm, params.phase_deg)], np.float64)
    optics = (A, B, float(np.cos(alpha2)), float(np.sin(alpha2)), float(params.index))
    from scan_patterns import risley_kernels  # numba, compiled on first use: importing the presets needs neither

    if clock is None:
        risley_kernels.trace_times(t_s, *optics, turns, out)
    else:
        risley_kernels.trace_clock(int(clock[0]), len(t_s), float(clock[1]), *optics, turns, out)
    return out
