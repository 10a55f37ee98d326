"""Fit the `rotors` model to an official table and store it (numpy least squares).

    python -m scan_patterns.fit_rotors [--table mid360] [--orders 3 12] [--lines rows] [-o scan_patterns/reference]

Where laser 0's azimuth goes round (Mid-360, turns = 1), f2 starts at the strongest line of its
elevation spectrum (parabolic peak between bins) and f1 at the azimuth's mean turn over whole periods
of f2 (which cancel delta's swing); where it swings back and forth (HAP, turns = 0), f1 starts at the
strongest line of its azimuth spectrum and f2 at the strongest line of its elevation below f1 / 2.
Both are then refined on laser 0's shots, each pair of rates scored by the best map for it
(`REFINE_SHOTS` shots), orders (1, 1) first, whose optimum is broad, then the orders asked for.
Per laser, elevation and azimuth - turns theta1 are linear in the Fourier coefficients: one least
squares each, on every shot. A row's laser is row mod lasers (`--lines rows`, the drivers' numbering)
or its rank in elevation among its neighbours (`--lines elevation`: HAP's rows come out of that order).
Writes <table>_rotors.npz (rates_hz, elevation, azimuth, turns: `rotors.RotorFit`) and prints the
errors; the results ship as scan_patterns/reference/mid360_rotors.npz and hap_rotors.npz.
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
LINE_WINDOW = 121  # rows whose mean elevation centres the stack of lasers (`elevation_lines`)
RETIME_STEP_S = 50e-6  # the most one round of `_retimed` moves a shot's time
RETIME_H_S = 1e-7  # time step of the paths' velocity (s)
CHUNK = 65_536  # shots in one basis at a time (bounds the memory of the normal equations' sums)


def _peak_hz(t_s: NDArray, signal: NDArray, below_hz: float = np.inf) -> float:
    """Frequency of the strongest line below `below_hz` of a real signal sampled evenly (parabolic peak
    between bins)."""
    spectrum = np.abs(np.fft.rfft(signal - signal.mean()))
    freqs = np.fft.rfftfreq(len(signal), float(np.median(np.diff(t_s))))
    k = int(np.argmax(np.where(freqs[1:-1] < below_hz, spectrum[1:-1], 0.0))) + 1
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
    rates: NDArray, t_s: NDArray, azimuth: NDArray, elevation: NDArray, orders: int, terms: int, turns: int
) -> NDArray:
    """Elevation and azimuth residuals (rad) of the best map for rates (f1, f2) Hz."""
    theta1, delta = cycles(t_s, rates[0]), cycles(t_s, rates[1])
    swing = _swing(azimuth, turns * theta1)
    basis = _basis(theta1, delta, orders, terms)
    real = np.hstack([basis.real, -basis.imag])
    ys = np.stack([elevation, swing], 1)
    solution, *_ = np.linalg.lstsq(real, ys, rcond=None)
    return (ys - real @ solution).ravel()


def _refine_rates(rates: tuple[float, float], t_s, azimuth, elevation, orders: int, terms: int,
                  turns: int) -> tuple[float, float]:
    """Rates (Hz) whose best map leaves the least residual on an even subset of one laser's shots:
    with orders (1, 1) first, then (orders, terms)."""
    take = slice(None, None, max(1, len(t_s) // REFINE_SHOTS))
    x = np.array(rates)
    for size in ((2, 3), (orders, terms)):
        args = (t_s[take], azimuth[take], elevation[take], *size, turns)
        x = least_squares(_map_residuals, x, args=args, diff_step=1e-9, xtol=1e-15, ftol=1e-15).x
    return float(x[0]), float(x[1])


def _swing(azimuth: NDArray, turned: NDArray) -> NDArray:
    """azimuth - turned (rad), within half a turn of its circular mean."""
    swing = azimuth - turned
    centre = np.angle(np.mean(np.exp(1j * swing)))
    return np.angle(np.exp(1j * (swing - centre))) + centre


def elevation_lines(elevation: NDArray, lasers: int) -> NDArray[np.intp]:
    """Each row's laser by its elevation (rad), for lasers stacked evenly in elevation (laser 0 lowest):
    its offset, in laser spacings, from the mean elevation of the `LINE_WINDOW` rows about it."""
    centre = np.convolve(elevation, np.ones(LINE_WINDOW) / LINE_WINDOW, "same")
    rounds = len(elevation) // lasers * lasers
    stacks = np.sort(elevation[:rounds].reshape(-1, lasers), axis=1)
    spacing = float(np.median(np.diff(stacks, axis=1)))  # most rounds hold each laser once
    return np.clip(np.round((elevation - centre) / spacing + (lasers - 1) / 2), 0, lasers - 1).astype(np.intp)


def fit(t_s: NDArray, dirs: NDArray, line: NDArray, orders: tuple[int, int], retime: int = 0) -> rotors.RotorFit:
    """Rates and per-laser coefficients of orders (M, K) from shots (times s, unit directions, lasers).
    With `retime` > 0, that many rounds of moving each shot's time to where the map passes closest to
    it (`_retimed`) and fitting the maps again at the rates found: for a table whose rows' times are
    off (HAP), the maps then draw the table's paths, not their blur."""
    azimuth, elevation = angles_from_dirs(dirs)
    first = line == 0
    turn = np.unwrap(azimuth[first])
    turns = int(abs(turn[-1] - turn[0]) > 2 * np.pi)  # goes round, or swings within a turn
    if turns:
        f2 = _peak_hz(t_s[first], elevation[first])
        dt = float(np.median(np.diff(t_s[first])))
        period = round(1.0 / f2 / dt)  # laser 0's shots in one turn of delta
        f1 = float((turn[period:] - turn[:-period]).mean() / (2 * np.pi * period * dt))
    else:
        f1 = _peak_hz(t_s[first], azimuth[first])
        f2 = _peak_hz(t_s[first], elevation[first], below_hz=f1 / 2)
    M, K = orders
    rates = _refine_rates((f1, f2), t_s[first], azimuth[first], elevation[first], M + 1, 2 * K + 1, turns)
    result = _maps(rates, t_s, azimuth, elevation, line, orders, turns)
    times = t_s
    for _ in range(retime):
        times = _retimed(result, times, azimuth, elevation, line)
        result = _maps(rates, times, azimuth, elevation, line, orders, turns)
    return result


def _maps(rates: tuple[float, float], t_s, azimuth, elevation, line, orders: tuple[int, int],
          turns: int) -> rotors.RotorFit:
    """Per laser, the best map of orders (M, K) for the rates (Hz): linear least squares on every shot."""
    M, K = orders
    lasers = int(line.max()) + 1
    coefficients = np.zeros((2, lasers, M + 1, 2 * K + 1), np.complex128)
    for laser in range(lasers):
        mine = line == laser
        theta1, delta = cycles(t_s[mine], rates[0]), cycles(t_s[mine], rates[1])
        coefficients[:, laser] = _real_fit(
            theta1, delta, (elevation[mine], _swing(azimuth[mine], turns * theta1)), M + 1, 2 * K + 1
        )
    return rotors.RotorFit(rates, coefficients[0], coefficients[1], turns)


def _retimed(result: rotors.RotorFit, t_s, azimuth, elevation, line) -> NDArray:
    """Each shot's time (s) moved along its laser's path to where the map passes closest to the shot
    (one linearised step, at most `RETIME_STEP_S`)."""
    at = np.stack(rotors.angles(result, t_s, line))
    velocity = (np.stack(rotors.angles(result, t_s + RETIME_H_S, line)) - at) / RETIME_H_S
    miss = np.stack([np.angle(np.exp(1j * (azimuth - at[0]))), elevation - at[1]])
    scale = np.stack([np.cos(elevation), np.ones_like(elevation)])  # azimuth on the sphere
    along = ((miss * scale) * (velocity * scale)).sum(0) / ((velocity * scale) ** 2).sum(0)
    return t_s + np.clip(along, -RETIME_STEP_S, RETIME_STEP_S)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scan_patterns.fit_rotors", description=__doc__.split("\n")[0])
    parser.add_argument("--table", default="mid360", help="official table name (default mid360)")
    parser.add_argument(
        "--orders", type=int, nargs=2, default=(3, 12), metavar=("M", "K"), help="harmonics of theta1, delta"
    )
    parser.add_argument("--lines", choices=("rows", "elevation"), default="rows",
                        help="a row's laser: row mod lasers (default), or its rank in elevation")
    parser.add_argument("--retime", type=int, default=0, metavar="N",
                        help="rounds of moving each row's time onto the map, then fitting the maps again")
    parser.add_argument("-o", "--out", type=Path, default=rotors.REFERENCE, help="folder of <table>_rotors.npz")
    args = parser.parse_args(argv)
    pattern = load_pattern_file(args.table)
    lasers = pattern.lasers or 1
    table_azimuth, table_elevation = angles_from_dirs(pattern.dirs)
    if args.lines == "rows":
        line = np.arange(len(pattern.t_s)) % lasers
    else:
        line = elevation_lines(table_elevation, lasers)
    result = fit(pattern.t_s, pattern.dirs, line, tuple(args.orders), args.retime)
    azimuth, elevation = rotors.angles(result, pattern.t_s, line)
    error = angle_between_deg(dirs_from_angles(azimuth, elevation), pattern.dirs)
    print(
        f"fitted to {pattern.name}: {len(line)} shots, f1 = {result.rates_hz[0]:.6f} Hz, f2 = {result.rates_hz[1]:.6f} "
        f"Hz"
    )
    print(f"  error at the rows' times: max {error.max():.2e} deg, rms {np.sqrt(np.mean(error**2)):.2e} deg")
    if args.retime:
        times = pattern.t_s
        for _ in range(args.retime):
            times = _retimed(result, times, table_azimuth, table_elevation, line)
        azimuth, elevation = rotors.angles(result, times, line)
        error = angle_between_deg(dirs_from_angles(azimuth, elevation), pattern.dirs)
        shift_us = (times - pattern.t_s) * 1e6
        print(f"  each row's time moved onto the map (rms {np.sqrt(np.mean(shift_us**2)):.1f} us, max "
              f"{np.abs(shift_us).max():.1f} us): max {error.max():.2e} deg, rms {np.sqrt(np.mean(error**2)):.2e} deg")
    args.out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.out / f"{args.table}_rotors.npz", rates_hz=np.array(result.rates_hz),
                        elevation=result.elevation, azimuth=result.azimuth, turns=result.turns)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
