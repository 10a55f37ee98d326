"""`risley`: the Livox Mid-40 optics, two wedge prisms rotating in opposite directions.

The beam leaves the laser along the head's x axis (the boresight) and crosses, in order:
prism 1's flat face, prism 1's wedged face, prism 2's wedged face, prism 2's flat face (the
wedged faces face each other; flat faces are normal to x). Snell's law in vector form is applied
at each of the four faces. A wedged face's normal is tilted by the wedge angle from x towards the
prism's angle theta, measured in the head's y-z plane from +y towards +z; theta = 2 pi rpm / 60 t +
phase. Identical prisms at the same angle make a parallel plate (the beam leaves on the
boresight); at opposite angles their deviations add up to the edge of the field of view.

`MID40` holds the parameters fitted to Livox's official Mid-40 file by `scan_patterns.fit_risley`
(max per-shot error 1.1e-5 deg in float64; `directions`, float32 optics, 2.9e-5 deg). Both prisms come out as the same glass and wedge, and the
rates as whole rpm; with 4664 and -7294 rpm (gcd 2 rpm) the pattern repeats only every 30 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scan_patterns.timebase import cycles

_BLOCK = 16384  # shots per block: the float32 temporaries of a block stay in the CPU cache


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


def trace(params: RisleyParams, cos1, sin1, cos2, sin2):
    """Exit direction (x, y, z) for prism angles given by their cosines and sines (arrays, same dtype).

    Prism 1 meets the beam on the boresight, so its output is one direction turned about x by
    theta1: traced once (scalars) at theta1 = 0, then rotated. Prism 2 is traced shot by shot.
    """
    dtype = np.result_type(cos1).type
    n = params.index
    alpha1, alpha2 = np.radians(params.wedge_deg)
    along, out, _ = _refract(_refract_flat((1.0, 0.0, 0.0), 1.0 / n), (np.cos(alpha1), np.sin(alpha1), 0.0), n)
    s = (dtype(along), dtype(out) * cos1, dtype(out) * sin1)  # out of prism 1
    wedge2 = (dtype(np.cos(alpha2)), dtype(np.sin(alpha2)) * cos2, dtype(np.sin(alpha2)) * sin2)
    s = _refract(s, wedge2, dtype(1.0 / n))  # into prism 2 through its wedged face
    return _refract_flat(s, dtype(n))  # out of prism 2 through its flat face


def prism_angles(params: RisleyParams, t_s: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Prism angles theta1, theta2 (radians, in [0, 2 pi), float64) at times `t_s`."""
    return tuple(
        cycles(t_s, rpm / 60.0, np.radians(phase)) for rpm, phase in zip(params.rpm, params.phase_deg)
    )


def directions_exact(params: RisleyParams, t_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3) float64 unit directions, head frame: the reference for fitting and tests."""
    th1, th2 = prism_angles(params, np.asarray(t_s, np.float64))
    return np.stack(trace(params, np.cos(th1), np.sin(th1), np.cos(th2), np.sin(th2)), axis=1)


def directions(params: RisleyParams, t_s: NDArray[np.float64]) -> NDArray[np.float32]:
    """(N, 3) float32 unit directions, head frame: phases in float64, optics in float32 (~1e-5 deg)."""
    t_s = np.asarray(t_s, np.float64)
    out = np.empty((len(t_s), 3), np.float32)
    for start in range(0, len(t_s), _BLOCK):
        block = slice(start, start + _BLOCK)
        th1, th2 = (a.astype(np.float32) for a in prism_angles(params, t_s[block]))
        x, y, z = trace(params, np.cos(th1), np.sin(th1), np.cos(th2), np.sin(th2))
        out[block, 0] = x
        out[block, 1] = y
        out[block, 2] = z
    return out
