"""`rotors`: a scanner of two elements turning at fixed rates, its optics a fitted map (Mid-360, HAP).

Livox's Mid-360 table is, to its own rounding, a function of two angles that turn at fixed rates:
theta1 = 2 pi f1 t (f1 = -182.4167 Hz, the azimuth's mean turn) and delta = 2 pi f2 t (f2 = 10 Hz).
For each laser l, at its shot's time t:

    elevation = Re sum_{m=0..M} sum_{k=-K..K} E[l, m, k] exp(i (m theta1 + k delta))
    azimuth   = turns theta1 + Re sum ... A[l, m, k] exp(i (m theta1 + k delta))

with turns = 1 where the azimuth goes round with theta1 (Mid-360) and 0 where it swings back and
forth (HAP: theta1 at 128.36 Hz, delta at 10.26 Hz; a map of them only, its rows' timing unknown, so
it misses HAP's table by about 1.7 deg rms, docs/scan_patterns.md).

`scan_patterns.fit_rotors` fits f1, f2 and the coefficients to the whole table and stores them in
scan_patterns/reference/<table>_rotors.npz. The turning is physical, so the model runs on past the
table without a seam (the Mid-360's theta1 and delta come back together every 12 s, not 4); the optics
between the elements and the beam (the Mid-360's leaves 38-97 deg from the axis, more than wedge prisms
bend it) are not modelled, only fitted: a map of (M + 1) (2 K + 1) terms per laser and angle.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scan_patterns.shots import dirs_from_angles
from scan_patterns.timebase import cycles

REFERENCE = Path(__file__).resolve().parent / "reference"
FITS = {"mid360": 4, "hap": 6}  # table -> its lasers: the fits stored as reference/<table>_rotors.npz


@dataclass(frozen=True)
class RotorParams:
    fit: str = "mid360"  # the table whose fit to use: reference/<fit>_rotors.npz

    def __post_init__(self) -> None:
        if self.fit not in FITS:
            raise ValueError(f"rotors: no fit of table {self.fit!r}; fitted: {', '.join(FITS)}")

    @property
    def lasers(self) -> int:
        return FITS[self.fit]


@dataclass(frozen=True)
class RotorFit:
    """Rates (Hz) of theta1 and delta, and per laser the complex coefficients (lasers, M + 1, 2 K + 1)
    of elevation and of azimuth - turns theta1 (radians); k runs from -K to K; turns: 1 or 0."""

    rates_hz: tuple[float, float]
    elevation: NDArray[np.complex128]
    azimuth: NDArray[np.complex128]
    turns: int


@functools.cache
def load(table: str) -> RotorFit:
    """The stored fit of `table` (reference/<table>_rotors.npz)."""
    with np.load(REFERENCE / f"{table}_rotors.npz") as data:
        rates = tuple(float(r) for r in data["rates_hz"])
        return RotorFit(rates, data["elevation"], data["azimuth"], int(data["turns"]))


def angles(fit: RotorFit, t_s: NDArray[np.float64], line: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(azimuth, elevation), radians float64, of lasers `line` at times `t_s` (s): the sums of elevation and
    azimuth - turns theta1 together in one compiled pass over the shots (`rotors_kernels.fourier_sums`), each pair
    of terms +-k folded into a k delta cosine and a sine."""
    t_s, line = np.asarray(t_s, np.float64), np.ascontiguousarray(line, np.intp)
    theta1, delta = cycles(t_s, fit.rates_hz[0]), cycles(t_s, fit.rates_hz[1])
    lasers, orders, terms = fit.elevation.shape
    coefficients = np.stack([fit.elevation, fit.azimuth], 1).transpose(0, 3, 1, 2).reshape(lasers, terms, 2 * orders)
    half = terms // 2
    up, down = coefficients[:, half:], coefficients[:, half::-1]  # k = 0..K and k = 0..-K
    cosine, sine = np.concatenate([up[:, :1], up[:, 1:] + down[:, 1:]], 1), 1j * (up - down)
    weights = np.stack([np.concatenate([part.real, part.imag], 2) for part in (cosine, sine)], 2)
    sums = np.empty((len(t_s), 2))
    from scan_patterns import rotors_kernels  # numba, compiled on first use: importing the presets needs neither

    rotors_kernels.fourier_sums(theta1, delta, line, weights, orders, sums)
    return fit.turns * theta1 + sums[:, 1], sums[:, 0]


def directions(params: RotorParams, t_s: NDArray[np.float64], line: NDArray) -> NDArray[np.float32]:
    """(N, 3) float32 head-frame unit directions of lasers `line` at times `t_s` (s)."""
    azimuth, elevation = angles(load(params.fit), t_s, line)
    return dirs_from_angles(azimuth, elevation).astype(np.float32)
