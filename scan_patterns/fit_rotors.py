"""Fit the `rotors` model to an official table and store it (numpy least squares).

    python -m scan_patterns.fit_rotors [--table mid360] [--orders 3 12] [-o scan_patterns/reference]

f2 starts at the strongest line of laser 0's elevation spectrum (parabolic peak between bins), f1
at the azimuth's mean turn over whole periods of f2 (which cancel delta's swing); both are then
refined on laser 0's shots, each pair of rates scored by the best map for it (`REFINE_SHOTS` shots).
Per laser, elevation and azimuth - theta1 are linear in the Fourier coefficients: one least squares
each, on every shot. Writes <table>_rotors.npz (rates_hz, elevation, azimuth: `rotors.RotorFit`) and prints the
errors; the result ships as scan_patterns/reference/mid360_rotors.npz.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from scan_patterns import rotors
from scan_patterns.replay import load_pattern_file
from scan_patterns.shots import angle_between_deg, angles_from_dirs, dirs_from_angles
from scan_patterns.timebase import cycles

REFINE_SHOTS = 20_000  # laser 0's shots, evenly spread over the table, that score a pair of rates
CHUNK = 65_536  # shots in one basis at a time (bounds the memory of the normal equations' sums)


def _peak_hz(t_s: NDArray, signal: NDArray) -> float:
    """Frequency of the strongest line of a real signal sampled evenly (parabolic peak between bins)."""
    spectrum = np.abs(np.fft.rfft(signal - signal.mean()))
    freqs = np.fft.rfftfreq(len(signal), float(np.median(np.diff(t_s))))
    k = int(np.argmax(spectrum[1:-1])) + 1
    a, b, c = np.log(spectrum[[k - 1, k, k + 1]])
    return float(freqs[k] + 0.5 * (a - c) / (a - 2 * b + c) * freqs[1])


def _basis(theta1: NDArray, delta: NDArray, orders: int, terms: int) -> NDArray:
    """(N, orders * terms) complex exp(i (m theta1 + k delta)), m in 0..orders-1, k in -K..K."""
    m, k = np.arange(orders), np.arange(terms) - terms // 2
    return (np.exp(1j * np.outer(theta1, m))[:, :, None] * np.exp(1j * np.outer(delta, k))[:, None, :]).reshape(
        len(theta1), -1
    )


def _real_fit(theta1: NDArray, delta: NDArray, ys: tuple[NDArray, ...], orders: int, terms: int) -> list[NDArray]:
    """Complex coefficients c (orders, terms) with Re(basis @ c) closest to each y: least squares on
    the cos and sin parts by normal equations, summed over chunks of shots (the basis is near orthogonal)."""
    size = 2 * orders * terms
    normal, right = np.zeros((size, size)), np.zeros((len(ys), size))
    for start in range(0, len(theta1), CHUNK):
        part = slice(start, start + CHUNK)
        basis = _basis(theta1[part], delta[part], orders, terms)
        real = np.hstack([basis.real, -basis.imag])
        normal += real.T @ real
        right += np.stack([y[part] for y in ys]) @ real
    solution = np.linalg.solve(normal + 1e-9 * np.eye(size), right.T).T
    half = size // 2
    return [(x[:half] + 1j * x[half:]).reshape(orders, terms) for x in solution]


def _map_residuals(
    rates: NDArray, t_s: NDArray, azimuth: NDArray, elevation: NDArray, orders: int, terms: int
) -> NDArray:
    """Elevation and azimuth residuals (rad) of the best map for rates (f1, f2) Hz."""
    theta1, delta = cycles(t_s, rates[0]), cycles(t_s, rates[1])
    swing = _swing(azimuth, theta1)
    basis = _basis(theta1, delta, orders, terms)
    real = np.hstack([basis.real, -basis.imag])
    ys = np.stack([elevation, swing], 1)
    solution, *_ = np.linalg.lstsq(real, ys, rcond=None)
    return (ys - real @ solution).ravel()


def _refine_rates(rates: tuple[float, float], t_s, azimuth, elevation, orders: int, terms: int) -> tuple[float, float]:
    """Rates (Hz) whose best map leaves the least residual on an even subset of one laser's shots."""
    take = slice(None, None, max(1, len(t_s) // REFINE_SHOTS))
    args = (t_s[take], azimuth[take], elevation[take], orders, terms)
    result = least_squares(_map_residuals, np.array(rates), args=args, diff_step=1e-9, xtol=1e-15, ftol=1e-15)
    return float(result.x[0]), float(result.x[1])


def _swing(azimuth: NDArray, theta1: NDArray) -> NDArray:
    """azimuth - theta1 (rad), within half a turn of its circular mean."""
    swing = azimuth - theta1
    centre = np.angle(np.mean(np.exp(1j * swing)))
    return np.angle(np.exp(1j * (swing - centre))) + centre


def fit(t_s: NDArray, dirs: NDArray, line: NDArray, orders: tuple[int, int]) -> rotors.RotorFit:
    """Rates and per-laser coefficients of orders (M, K) from shots (times s, unit directions, lasers)."""
    azimuth, elevation = angles_from_dirs(dirs)
    first = line == 0
    f2 = _peak_hz(t_s[first], elevation[first])
    dt = float(np.median(np.diff(t_s[first])))
    period = round(1.0 / f2 / dt)  # laser 0's shots in one turn of delta
    turn = np.unwrap(azimuth[first])
    f1 = float((turn[period:] - turn[:-period]).mean() / (2 * np.pi * period * dt))
    M, K = orders
    f1, f2 = _refine_rates((f1, f2), t_s[first], azimuth[first], elevation[first], M + 1, 2 * K + 1)
    lasers = int(line.max()) + 1
    coefficients = np.zeros((2, lasers, M + 1, 2 * K + 1), np.complex128)
    for laser in range(lasers):
        mine = line == laser
        theta1, delta = cycles(t_s[mine], f1), cycles(t_s[mine], f2)
        coefficients[:, laser] = _real_fit(
            theta1, delta, (elevation[mine], _swing(azimuth[mine], theta1)), M + 1, 2 * K + 1
        )
    return rotors.RotorFit((f1, f2), coefficients[0], coefficients[1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scan_patterns.fit_rotors", description=__doc__.split("\n")[0])
    parser.add_argument("--table", default="mid360", help="official table name (default mid360)")
    parser.add_argument(
        "--orders", type=int, nargs=2, default=(3, 12), metavar=("M", "K"), help="harmonics of theta1, delta"
    )
    parser.add_argument("-o", "--out", type=Path, default=rotors.REFERENCE, help="folder of <table>_rotors.npz")
    args = parser.parse_args(argv)
    pattern = load_pattern_file(args.table)
    line = np.arange(len(pattern.t_s)) % (pattern.lasers or 1)
    result = fit(pattern.t_s, pattern.dirs, line, tuple(args.orders))
    azimuth, elevation = rotors.angles(result, pattern.t_s, line)
    error = angle_between_deg(dirs_from_angles(azimuth, elevation), pattern.dirs)
    print(
        f"fitted to {pattern.name}: {len(line)} shots, f1 = {result.rates_hz[0]:.6f} Hz, f2 = {result.rates_hz[1]:.6f} "
        f"Hz"
    )
    print(f"  error: max {error.max():.2e} deg, rms {np.sqrt(np.mean(error**2)):.2e} deg")
    args.out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.out / f"{args.table}_rotors.npz", rates_hz=np.array(result.rates_hz),
                        elevation=result.elevation, azimuth=result.azimuth)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
