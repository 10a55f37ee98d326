"""`scan_patterns.rotors.angles`' compiled loop (numba): imported when angles are first asked for,
so that reading presets and scenarios needs no numba."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def fourier_sums(theta1, delta, line, weights, orders, out):
    """out[n, r] = Re sum_m S[r orders + m] exp(i m theta1[n]), S[q] = sum_{k=0..K} (a[k, q] cos k delta[n]
    + b[k, q] sin k delta[n]), for laser line[n]'s weights (K + 1, 2, 2 Q): [k, 0] = (Re a, Im a), [k, 1] =
    (Re b, Im b), q < Q = rows * orders. cos and sin of k delta by repeated rotation (error ~ K ulp)."""
    terms, width = weights.shape[1], weights.shape[3] // 2
    acc = np.empty(2 * width)
    for n in range(len(theta1)):
        w = weights[line[n]]
        c, s = np.cos(delta[n]), np.sin(delta[n])
        ck, sk = 1.0, 0.0
        acc[:] = w[0, 0]
        for k in range(1, terms):
            ck, sk = ck * c - sk * s, sk * c + ck * s
            for q in range(2 * width):
                acc[q] += w[k, 0, q] * ck + w[k, 1, q] * sk
        c1, s1 = np.cos(theta1[n]), np.sin(theta1[n])
        for r in range(width // orders):
            total, zc, zs = 0.0, 1.0, 0.0
            for m in range(orders):
                total += acc[r * orders + m] * zc - acc[width + r * orders + m] * zs
                zc, zs = zc * c1 - zs * s1, zs * c1 + zc * s1
            out[n, r] = total
