"""`risley`: rotating wedge prisms (a Risley pair, or three for the Horizon), one or several lasers.

Each laser's beam enters along its own direction (`lasers_deg`: azimuth and elevation in the head
frame, x forward; the Mid-40's single laser on the boresight) and crosses the prisms in order. A
prism has a flat face (normal along x) and a wedged face whose normal is tilted by the wedge angle
from x towards the prism's angle theta, measured in the head's y-z plane from +y towards +z; theta =
2 pi rpm / 60 t + phase. `wedged_first` says which face the beam meets first. Snell's law in
vector form is applied at every face. The lasers take turns (shot k fires laser (k - 1) mod L) and
a round of L shots fires at one prism position, that of the round's first shot: so do Livox's
tables (the phases of each laser's spectral lines differ by exactly the shot spacing times their
frequency); the drivers stamp the shots of a round 1 / rate apart.

`FITTED` holds, by official table name, the parameters fitted to Livox's tables by
`scan_patterns.fit_risley` (docs/scan_patterns.md: per-shot errors of about 1e-5 deg, the precision
of the float32 copies), all whole rpm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scan_patterns.shots import dirs_from_angles
from scan_patterns.timebase import cycles


@dataclass(frozen=True)
class RisleyParams:
    """Rotating wedge prisms, in the order the beam meets them, and the lasers feeding them."""

    wedge_deg: tuple[float, ...]  # wedge angle of each prism
    index: float | tuple[float, ...]  # refractive index at the laser's wavelength: all prisms, or each
    rpm: tuple[float, ...]  # rotation rates, revolutions per minute, + = from +y towards +z
    phase_deg: tuple[float, ...]  # prism angles theta at t = 0
    wedged_first: tuple[bool, ...] = (False, True)  # per prism: the beam meets its wedged face first
    lasers_deg: tuple[tuple[float, float], ...] = ((0.0, 0.0),)  # (azimuth, elevation) of each laser's beam

    def __post_init__(self) -> None:
        count = len(self.wedge_deg)
        if not 1 <= count <= 4:
            raise ValueError(f"risley: 1 to 4 prisms, got {count} wedge angles")
        fields = {"rpm": self.rpm, "phase_deg": self.phase_deg, "wedged_first": self.wedged_first}
        if not isinstance(self.index, (int, float)):
            fields["index"] = self.index
        for name, values in fields.items():
            if len(values) != count:
                raise ValueError(f"risley: {name} has {len(values)} values for {count} prisms")
        for index in self.indices:
            if not index > 1.0:
                raise ValueError(f"risley: refractive index must exceed 1, got {index}")
        for wedge in self.wedge_deg:
            if not 0.0 < wedge < 45.0:
                raise ValueError(f"risley: wedge angle must be in (0, 45) degrees, got {wedge}")
        try:
            lasers = tuple((float(az), float(el)) for az, el in self.lasers_deg)
        except (TypeError, ValueError):
            lasers = ()
        if not 1 <= len(lasers) <= 255 or any(max(map(abs, laser)) >= 30 for laser in lasers):
            raise ValueError("risley: lasers_deg holds 1 to 255 (azimuth, elevation) pairs within 30 degrees of the "
                             "boresight")
        object.__setattr__(self, "lasers_deg", lasers)

    @property
    def indices(self) -> tuple[float, ...]:
        """Refractive index of each prism."""
        if isinstance(self.index, (int, float)):
            return (float(self.index),) * len(self.wedge_deg)
        return tuple(float(n) for n in self.index)

    @property
    def lasers(self) -> int:
        return len(self.lasers_deg)


# Fitted by `python -m scan_patterns.fit_risley --optics NAME` to Livox's tables, which it returns to
# within 1e-5 deg (wedges, phases, lasers), 1e-6 (index) and 1e-6 rpm of these round values from a
# strided subset (Mid-40, Mid-70, Avia, Tele-15; docs/scan_patterns.md); every set leaves under 2e-5
# deg over its whole table.
MID40 = RisleyParams(wedge_deg=(18.0, 18.0), index=1.5089, rpm=(-7294.0, 4664.0), phase_deg=(180.0, 0.0))
# Avia: six lasers in a vertical row (tangents 0.4488 deg x 1, 3, 5 either side of the boresight), the
# wedged faces outwards in a glass of index 1.8144; the prisms stand at 180 and 0 deg at the first shot.
AVIA = RisleyParams(wedge_deg=(18.0, 18.0), index=1.8144, rpm=(-7893.0, 2448.0), phase_deg=(180.197325, -0.0612),
                    wedged_first=(True, False),
                    lasers_deg=((0.0, -2.242938), (0.0, -1.346203), (0.0, -0.448808),
                                (0.0, 0.448808), (0.0, 1.346203), (0.0, 2.242938)))
# Tele-15: the Avia's layout with thin wedges of the Mid-40's glass and a narrower row of lasers
# (tangents 0.1584 deg x 1, 3, 5); the prisms stand at 180 and 0 deg five shots before t = 0.
TELE15 = RisleyParams(wedge_deg=(7.1, 7.1), index=1.5089, rpm=(-9837.0, 3087.0), phase_deg=(178.770375, 0.385875),
                      wedged_first=(True, False),
                      lasers_deg=((0.0, -0.791979), (0.0, -0.475207), (0.0, -0.158406),
                                  (0.0, 0.158406), (0.0, 0.475207), (0.0, 0.791979)))
# Horizon: two prisms of one glass turning at +-7352 rpm draw a horizontal line, a third of another
# glass at 619 rpm moves it about; the Avia's six lasers; every prism at 180 or 0 deg five shots before t = 0.
HORIZON = RisleyParams(wedge_deg=(20.0, 20.0, 17.5), index=(1.6106, 1.6106, 1.5799), rpm=(7352.0, -7352.0, 619.0),
                       phase_deg=(180.919, -0.919, 180.077375), wedged_first=(True, False, True),
                       lasers_deg=AVIA.lasers_deg)
# Mid-70: the Mid-40's wedges, rates and phases in a glass of index 1.8144 (the Avia's), with the
# Avia's face order (wedged faces outwards).
MID70 = RisleyParams(wedge_deg=(18.0, 18.0), index=1.8144, rpm=(-7294.0, 4664.0), phase_deg=(180.0, 0.0),
                     wedged_first=(True, False))
FITTED = {"mid40": MID40, "mid70": MID70, "avia": AVIA, "tele": TELE15, "horizon": HORIZON}


def _refract(s, normal, eta):
    """Snell's law, vector form: direction `s` crossing a face with unit `normal` (s . normal > 0).

    `eta` is n_before / n_after. Works on tuples of arrays (any dtype) or scalars, broadcasting.
    """
    sx, sy, sz = s
    nx, ny, nz = normal
    cos_in = sx * nx + sy * ny + sz * nz
    k = np.sqrt(1.0 - eta * eta * (1.0 - cos_in * cos_in)) - eta * cos_in
    return eta * sx + k * nx, eta * sy + k * ny, eta * sz + k * nz


def laser_dirs(params: RisleyParams) -> NDArray[np.float64]:
    """(L, 3) unit directions of the lasers' beams before the first prism."""
    angles = np.radians(np.asarray(params.lasers_deg, np.float64))
    return dirs_from_angles(angles[:, 0], angles[:, 1])


def trace(params: RisleyParams, cos_theta, sin_theta, beams):
    """Exit directions (x, y, z) of beams (x, y, z) through the prisms at angles given by their cosines
    and sines (one array per prism): the float64 reference, Snell's law at every face."""
    s = beams
    prisms = zip(np.radians(params.wedge_deg), params.indices, params.wedged_first, cos_theta, sin_theta, strict=True)
    for alpha, n, wedged_first, c, si in prisms:
        wedge = (np.cos(alpha), np.sin(alpha) * c, np.sin(alpha) * si)
        flat = (1.0, 0.0, 0.0)
        for face, eta in zip((wedge, flat) if wedged_first else (flat, wedge), (1.0 / n, n)):
            s = _refract(s, face, eta)
    return s


def prism_angles(params: RisleyParams, t_s: NDArray[np.float64]) -> tuple[NDArray, ...]:
    """Prism angles (radians, in [0, 2 pi), float64) at times `t_s`, one array per prism."""
    return tuple(cycles(t_s, rpm / 60.0, np.radians(phase)) for rpm, phase in zip(params.rpm, params.phase_deg))


def round_times(t_s: NDArray[np.float64], line: NDArray, rate_hz: float) -> NDArray[np.float64]:
    """Time of each shot's round (its first shot), the time its prism position is taken at: shots of
    laser `line` on a clock of `rate_hz`."""
    return np.asarray(t_s, np.float64) - np.asarray(line, np.float64) / rate_hz


def directions_exact(
    params: RisleyParams, t_s: NDArray[np.float64], line: NDArray | None = None
) -> NDArray[np.float64]:
    """(N, 3) float64 unit directions, head frame, of lasers `line` (default 0) with the prisms at
    times `t_s` (for several lasers: `round_times`): the reference for fitting and tests."""
    t_s = np.asarray(t_s, np.float64)
    beams = laser_dirs(params)[np.zeros(len(t_s), np.intp) if line is None else np.asarray(line, np.intp)]
    theta = prism_angles(params, t_s)
    return np.stack(trace(params, [np.cos(a) for a in theta], [np.sin(a) for a in theta], tuple(beams.T)), axis=1)


def directions(
    params: RisleyParams, t_s: NDArray[np.float64], clock: tuple[int, float] | None = None, line: NDArray | None = None
) -> NDArray[np.float32]:
    """(N, 3) float32 unit directions, head frame: `trace` in a compiled loop, fast.

    With `clock` = (first shot index, shots per second), the shots are a head's shot clock, shot k at
    k / rate firing laser (k - 1) mod L, and the prisms are taken at each round's first shot (`t_s`
    and `line` are then implied): their angles are exact at every round whose index is divisible by
    `risley_kernels.ANCHOR` and advanced by a fixed rotation in between, so a shot's direction depends on its index
    alone, whatever window asks for it. Without, the prisms are taken exactly at `t_s`, for lasers
    `line` (default 0). Float64 inside (phases reduced to one turn, so exact at any time), float32 out.
    """
    t_s = np.ascontiguousarray(t_s, np.float64)
    out = np.empty((len(t_s), 3), np.float32)
    alpha = np.radians(np.asarray(params.wedge_deg, np.float64))
    indices, wedged_first = np.asarray(params.indices, np.float64), np.asarray(params.wedged_first, np.bool_)
    optics = (np.cos(alpha), np.sin(alpha), indices, wedged_first)
    turns = np.array([(rpm / 60.0, phase / 360.0) for rpm, phase in zip(params.rpm, params.phase_deg)], np.float64)
    beams = np.ascontiguousarray(laser_dirs(params))
    from scan_patterns import risley_kernels  # numba, compiled on first use: importing the presets needs neither

    if clock is None:
        lines = np.zeros(len(t_s), np.intp) if line is None else np.ascontiguousarray(line, np.intp)
        risley_kernels.trace_times(t_s, lines, beams, *optics, turns, out)
    else:
        risley_kernels.trace_clock(int(clock[0]), len(t_s), float(clock[1]), beams, *optics, turns, out)
    return out
