"""Fit the `risley` model to an official pattern file (scipy least squares); prints the parameters.

    python -m scan_patterns.fit_risley [--file mid40] [--stride 1]

The start comes from the file itself: the two strongest lines of the spectrum of the lateral
direction y + i z are the two prisms (frequency -> rpm, amplitude -> wedge, phase -> prism angle).
Least squares then fits wedge angles, refractive index, rates and phases, first on the first
0.25 s, then on the whole file. Prism 1's wedge and the index are not separable from prism 1
alone, but prism 2 pins the index. The result is `risley.MID40`.
"""

from __future__ import annotations

import argparse
import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from scan_patterns.replay import load_pattern_file
from scan_patterns.risley import MID40, RisleyParams, directions_exact
from scan_patterns.shots import angle_between_deg

START_WINDOW_S = 0.25


@dataclass(frozen=True)
class RisleyFit:
    params: RisleyParams
    max_error_deg: float  # largest angle between model and file directions
    rms_error_deg: float


def _params(p: NDArray) -> RisleyParams:
    return RisleyParams(wedge_deg=(p[0], p[1]), index=p[2], rpm=(p[3], p[4]), phase_deg=(p[5], p[6]))


def _residuals(p: NDArray, t_s: NDArray, dirs: NDArray) -> NDArray:
    return (directions_exact(_params(p), t_s) - dirs).ravel()


def spectral_lines(t_s: NDArray, dirs: NDArray) -> list[tuple[float, float, float]]:
    """The two strongest lines of y + i z: (Hz, amplitude, phase at t = 0 in rad), strongest first."""
    w = dirs[:, 1] + 1j * dirs[:, 2]
    dt = float(np.median(np.diff(t_s)))
    spectrum = np.fft.fft(w)
    freqs = np.fft.fftfreq(len(w), dt)
    lines = []
    for sign in (1, -1):  # one line each way round: the prisms turn in opposite directions
        power = np.where(sign * freqs > 0, np.abs(spectrum), 0.0)
        k = int(np.argmax(power))
        a, b, c = np.log(np.abs(spectrum[[k - 1, k, k + 1]]))
        shift = 0.5 * (a - c) / (a - 2 * b + c)  # parabolic peak between bins
        hz = freqs[k] + shift * freqs[1]
        amplitude = np.abs(np.mean(w * np.exp(-2j * np.pi * hz * t_s)))
        phase = float(np.angle(np.mean(w * np.exp(-2j * np.pi * hz * t_s))))
        lines.append((hz, amplitude, phase))
    return sorted(lines, key=lambda line: -line[1])


def _least_squares(p0: NDArray, t_s: NDArray, dirs: NDArray) -> NDArray:
    lower = [1.0, 1.0, 1.05, -1e5, -1e5, -720.0, -720.0]
    upper = [44.0, 44.0, 4.0, 1e5, 1e5, 720.0, 720.0]
    p0 = np.clip(p0, np.add(lower, 1e-9), np.subtract(upper, 1e-9))
    result = least_squares(_residuals, p0, args=(t_s, dirs), bounds=(lower, upper), x_scale="jac", xtol=1e-12)
    return result.x


def fit(t_s: NDArray, dirs: NDArray) -> RisleyFit:
    """Fit a Risley pair to shots (times in s, head-frame unit directions)."""
    lines = spectral_lines(t_s, dirs)
    start = t_s < t_s[0] + START_WINDOW_S
    best, best_cost = None, np.inf
    index0 = 1.5
    for (line1, line2), flips in itertools.product(
        itertools.permutations(lines), itertools.product((0, 180), repeat=2)
    ):
        wedges = [np.degrees(np.arcsin(amp)) / (index0 - 1.0) for _, amp, _ in (line1, line2)]
        rpms = [60.0 * hz for hz, _, _ in (line1, line2)]
        phases = [np.degrees(ph) + flip for (_, _, ph), flip in zip((line1, line2), flips)]
        p = _least_squares(np.array([*wedges, index0, *rpms, *phases]), t_s[start], dirs[start])
        cost = np.sum(_residuals(p, t_s[start], dirs[start]) ** 2)
        if cost < best_cost:
            best, best_cost = p, cost
    p = _least_squares(best, t_s, dirs)
    p[5:] = np.mod(p[5:] + 180.0, 360.0) - 180.0
    params = _params(p)
    error = angle_between_deg(directions_exact(params, t_s), dirs)
    return RisleyFit(params, float(error.max()), float(np.sqrt(np.mean(error**2))))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scan_patterns.fit_risley", description=__doc__.split("\n")[0])
    parser.add_argument("--file", default="mid40", help="official name (mid40) or path to .npz / .csv")
    parser.add_argument("--stride", type=int, default=1, help="fit every stride-th shot (default: all)")
    args = parser.parse_args(argv)
    pattern = load_pattern_file(args.file)
    t_s, dirs = pattern.t_s[:: args.stride], pattern.dirs[:: args.stride]
    result = fit(t_s, dirs)
    p = result.params
    print(f"fitted to {pattern.name}: {len(t_s)} shots")
    print(f"  wedge_deg = ({p.wedge_deg[0]:.6f}, {p.wedge_deg[1]:.6f})")
    print(f"  index     = {p.index:.6f}")
    print(f"  rpm       = ({p.rpm[0]:.6f}, {p.rpm[1]:.6f})")
    print(f"  phase_deg = ({p.phase_deg[0]:.6f}, {p.phase_deg[1]:.6f})")
    print(f"  error: max {result.max_error_deg:.2e} deg, rms {result.rms_error_deg:.2e} deg")
    stored = angle_between_deg(directions_exact(MID40, pattern.t_s), pattern.dirs)
    print(f"stored risley.MID40 on all {len(stored)} shots: max {stored.max():.2e} deg")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
