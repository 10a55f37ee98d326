"""Fit the `risley` model to an official table (scipy least squares); prints the parameters.

    python -m scan_patterns.fit_risley [--optics mid40|mid70|avia|tele|horizon] [--stride 1]

The optics' layout (how many prisms, which face each meets first, one glass or one per prism, how
many lasers) comes from the stored model of that name (`risley.FITTED`); every number comes from the
table itself. The strongest lines of the spectrum of one laser's lateral direction y + i z are the
prisms (frequency -> rpm, amplitude -> wedge, phase -> prism angle). Every assignment of lines to
prisms and both orientations of each wedge are tried on the first 0.25 s, with the lasers on the
boresight; least squares then fits wedge angles, indices, rates, phases and each laser's direction
on the whole table (every `stride`-th shot). A round of lasers is taken at its first shot's time
(`risley.round_times`). Prism 1's wedge and index are not separable for a single laser on the
boresight (the Mid-40), but the next prism pins the index.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from scan_patterns.replay import load_pattern_file
from scan_patterns.risley import FITTED, RisleyParams, directions_exact, round_times
from scan_patterns.shots import angle_between_deg

START_WINDOW_S = 0.25
INDEX0 = 1.5  # the glass the search starts from


@dataclass(frozen=True)
class RisleyFit:
    params: RisleyParams
    max_error_deg: float  # largest angle between model and file directions
    rms_error_deg: float


@dataclass(frozen=True)
class _Layout:
    """What is not fitted: the template's prisms, faces, glasses and lasers."""

    template: RisleyParams

    @property
    def prisms(self) -> int:
        return len(self.template.wedge_deg)

    @property
    def glasses(self) -> int:
        return 1 if isinstance(self.template.index, (int, float)) else self.prisms

    def params(self, p: NDArray) -> RisleyParams:
        """Parameters from the vector: wedges, indices, rpm, phases, laser azimuth/elevation pairs."""
        k, g = self.prisms, self.glasses
        index = float(p[k]) if g == 1 else tuple(p[k : k + g])
        fixed = 3 * k + g
        lasers = tuple((float(a), float(e)) for a, e in p[fixed:].reshape(-1, 2))
        return dataclasses.replace(self.template, wedge_deg=tuple(p[:k]), index=index, rpm=tuple(p[k + g : 2 * k + g]),
                                   phase_deg=tuple(p[2 * k + g : fixed]), lasers_deg=lasers)

    def bounds(self) -> tuple[list, list]:
        k, g, lasers = self.prisms, self.glasses, self.template.lasers
        return ([0.01] * k + [1.05] * g + [-1e5] * k + [-720.0] * k + [-29.0] * 2 * lasers,
                [44.9] * k + [4.0] * g + [1e5] * k + [720.0] * k + [29.0] * 2 * lasers)


def _residuals(p: NDArray, layout: _Layout, t_s: NDArray, line: NDArray, dirs: NDArray) -> NDArray:
    """Model minus table, per component; a beam the prisms reflect back (no exit) counts 1 per component."""
    with np.errstate(invalid="ignore"):
        return np.nan_to_num(directions_exact(layout.params(p), t_s, line) - dirs, nan=1.0).ravel()


def spectral_lines(t_s: NDArray, dirs: NDArray, count: int = 2) -> list[tuple[float, float, float]]:
    """The `count` strongest lines of y + i z, at least 4 bins apart: (Hz, amplitude, phase at t = 0
    in rad), strongest first (evenly spaced shots)."""
    w = dirs[:, 1] + 1j * dirs[:, 2]
    dt = float(np.median(np.diff(t_s)))
    spectrum = np.abs(np.fft.fft(w))
    freqs = np.fft.fftfreq(len(w), dt)
    lines = []
    for _ in range(count):
        k = int(np.argmax(spectrum))
        a, b, c = np.log(spectrum[[k - 1, k, (k + 1) % len(w)]])
        hz = freqs[k] + 0.5 * (a - c) / (a - 2 * b + c) * freqs[1]  # parabolic peak between bins
        line = np.mean(w * np.exp(-2j * np.pi * hz * t_s))
        lines.append((hz, float(np.abs(line)), float(np.angle(line))))
        spectrum[max(0, k - 4) : k + 5] = 0.0
    return lines


def _wedge_deg(amplitude: float) -> float:
    """Wedge angle of a prism of index INDEX0 that deviates a beam (normal on its flat face) by asin(amplitude)."""
    deviation = np.arcsin(min(amplitude, 0.9))
    return float(np.degrees(np.arctan(np.sin(deviation) / (INDEX0 - np.cos(deviation)))))


def _least_squares(p0: NDArray, layout: _Layout, t_s: NDArray, line: NDArray, dirs: NDArray, **kw) -> NDArray:
    lower, upper = layout.bounds()
    p0 = np.clip(p0, np.add(lower, 1e-9), np.subtract(upper, 1e-9))
    return least_squares(_residuals, p0, args=(layout, t_s, line, dirs), bounds=(lower, upper), x_scale="jac", **kw).x


def fit(t_s: NDArray, dirs: NDArray, template: RisleyParams = FITTED["mid40"], line: NDArray | None = None,
        rate_hz: float = 1.0) -> RisleyFit:
    """Fit prisms laid out as `template` to shots (times in s, head-frame unit directions) of lasers
    `line` (default all laser 0) on a clock of `rate_hz`, from the shots alone."""
    layout = _Layout(template)
    line = np.zeros(len(t_s), np.intp) if line is None else np.asarray(line, np.intp)
    rounds = round_times(t_s, line, rate_hz)
    first = line == 0
    lines = spectral_lines(t_s[first], dirs[first], layout.prisms)
    start = rounds < rounds[0] + START_WINDOW_S
    lasers = np.zeros(2 * template.lasers)
    best, best_cost = None, np.inf
    for order, flips in itertools.product(
        itertools.permutations(lines), itertools.product((0, 180), repeat=layout.prisms)
    ):
        wedges = [_wedge_deg(amp) for _, amp, _ in order]
        rpms = [60.0 * hz for hz, _, _ in order]
        phases = [np.degrees(ph) + flip for (_, _, ph), flip in zip(order, flips)]
        p = np.array([*wedges, *[INDEX0] * layout.glasses, *rpms, *phases, *lasers])
        p = _least_squares(p, layout, rounds[start], line[start], dirs[start], max_nfev=200 * len(p))
        cost = np.sum(_residuals(p, layout, rounds[start], line[start], dirs[start]) ** 2)
        if cost < best_cost:
            best, best_cost = p, cost
    p = _least_squares(best, layout, rounds, line, dirs, xtol=1e-15, ftol=1e-15)
    phases = slice(2 * layout.prisms + layout.glasses, 3 * layout.prisms + layout.glasses)
    p[phases] = np.mod(p[phases] + 180.0, 360.0) - 180.0
    params = layout.params(p)
    error = angle_between_deg(directions_exact(params, rounds, line), dirs)
    return RisleyFit(params, float(error.max()), float(np.sqrt(np.mean(error**2))))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scan_patterns.fit_risley", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--optics",
        default="mid40",
        choices=sorted(FITTED),
        help="the table, and the stored model whose layout is fitted",
    )
    parser.add_argument("--stride", type=int, default=1, help="fit every stride-th shot (default: all)")
    args = parser.parse_args(argv)
    pattern = load_pattern_file(args.optics)
    stored = FITTED[args.optics]
    line = np.arange(len(pattern.t_s)) % stored.lasers
    rate = 1.0 / pattern.dt_s
    take = slice(None, None, args.stride)
    result = fit(pattern.t_s[take], pattern.dirs[take], stored, line[take], rate)
    p = result.params
    print(f"fitted to {pattern.name}: {len(pattern.t_s[take])} shots")
    print(f"  wedge_deg = ({', '.join(f'{v:.7f}' for v in p.wedge_deg)})")
    print(f"  index     = ({', '.join(f'{v:.8f}' for v in p.indices)})")
    print(f"  rpm       = ({', '.join(f'{v:.7f}' for v in p.rpm)})")
    print(f"  phase_deg = ({', '.join(f'{v:.7f}' for v in p.phase_deg)})")
    print(f"  lasers_deg = ({', '.join(f'({a:.7f}, {e:.7f})' for a, e in p.lasers_deg)})")
    print(f"  error: max {result.max_error_deg:.2e} deg, rms {result.rms_error_deg:.2e} deg")
    error = angle_between_deg(directions_exact(stored, round_times(pattern.t_s, line, rate), line), pattern.dirs)
    print(
        f"stored risley.FITTED[{args.optics!r}] on all {len(error)} shots: max {error.max():.2e} deg, rms "
        f"{np.sqrt(np.mean(error**2)):.2e} deg"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
